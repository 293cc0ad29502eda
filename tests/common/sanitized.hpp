// ROLLSTEP_SANITIZED is 1 in a build under AddressSanitizer or ThreadSanitizer: they
// interpose malloc themselves, so the allocation counters must not. GCC defines
// __SANITIZE_ADDRESS__ / __SANITIZE_THREAD__; clang 14 only answers __has_feature.
#pragma once

#if defined(__SANITIZE_ADDRESS__) || defined(__SANITIZE_THREAD__)
#define ROLLSTEP_SANITIZED 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer) || __has_feature(thread_sanitizer)
#define ROLLSTEP_SANITIZED 1
#endif
#endif
#ifndef ROLLSTEP_SANITIZED
#define ROLLSTEP_SANITIZED 0
#endif
