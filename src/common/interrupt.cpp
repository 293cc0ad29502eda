#include "rollstep/common/interrupt.hpp"

#include <signal.h>

#include <atomic>
#include <cerrno>
#include <cstring>

namespace rollstep {
namespace {

constexpr int kMaxChildren = 512;  // trials --jobs runs up to 256 at once
std::atomic<int> g_signal{0};
std::atomic<bool> g_deferred{false};
std::atomic<pid_t> g_children[kMaxChildren];

extern "C" void onInterrupt(int signal_number) {
  const int saved_errno = errno;
  for (std::atomic<pid_t>& child : g_children) {
    const pid_t pid = child.load();
    if (pid > 0) ::kill(pid, signal_number);
  }
  int expected = 0;
  g_signal.compare_exchange_strong(expected, signal_number);
  if (!g_deferred.load()) {
    // Nothing to clean up yet: end as the signal would have ended us.
    ::signal(signal_number, SIG_DFL);
    ::raise(signal_number);
  }
  errno = saved_errno;
}

}  // namespace

Interrupted::Interrupted(int signal_number)
    : std::runtime_error("interrupted by " + signalName(signal_number)), signal_(signal_number) {}

void installInterruptHandlers() {
  struct sigaction action;
  std::memset(&action, 0, sizeof action);
  action.sa_handler = onInterrupt;
  sigemptyset(&action.sa_mask);
  action.sa_flags = 0;  // no SA_RESTART
  for (int s : {SIGINT, SIGTERM, SIGHUP}) {
    // A signal this process was started ignoring stays ignored: SIGHUP under nohup, SIGINT
    // in a script's background job (the terminal's Ctrl-C is not for it).
    struct sigaction inherited;
    if (::sigaction(s, nullptr, &inherited) == 0 && inherited.sa_handler == SIG_IGN) continue;
    ::sigaction(s, &action, nullptr);
  }
}

void deferInterrupts() noexcept { g_deferred.store(true); }

bool interruptRequested() noexcept { return g_signal.load(std::memory_order_relaxed) != 0; }

int interruptSignal() noexcept { return g_signal.load(); }

void throwIfInterrupted() {
  if (const int s = g_signal.load(std::memory_order_relaxed); s != 0) throw Interrupted(s);
}

std::string signalName(int signal_number) {
  switch (signal_number) {
    case SIGINT:
      return "SIGINT";
    case SIGTERM:
      return "SIGTERM";
    case SIGHUP:
      return "SIGHUP";
    case SIGKILL:
      return "SIGKILL";
    default:
      return "signal " + std::to_string(signal_number);
  }
}

void registerChild(pid_t pid) noexcept {
  for (std::atomic<pid_t>& child : g_children) {
    pid_t expected = 0;
    if (child.compare_exchange_strong(expected, pid)) return;
  }
}

void unregisterChild(pid_t pid) noexcept {
  for (std::atomic<pid_t>& child : g_children) {
    pid_t expected = pid;
    if (child.compare_exchange_strong(expected, 0)) return;
  }
}

}  // namespace rollstep
