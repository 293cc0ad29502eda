// Interrupts: before deferInterrupts() a signal ends the process by its own default action;
// after it, the first signal is recorded and nothing else happens; an ignored signal stays
// ignored; registered children get the signal forwarded; a blocking call returns EINTR.
// Signal dispositions are process-wide, so every case runs in a forked child and reports
// through its exit status (0 = every check held, else the number of the failed check).
#include "rollstep/common/interrupt.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdlib>
#include <string>

namespace rollstep {
namespace {

/// Runs `body` in a forked child; the child's wait status.
template <typename Body>
int inChild(Body body) {
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::_exit(body());
  }
  int status = 0;
  EXPECT_EQ(::waitpid(pid, &status, 0), pid);
  return status;
}

/// A child that sleeps until it is signalled (at most 10 s, then exits 42). SIGTERM is
/// blocked across the fork, so a SIGTERM that comes early waits for the child's default
/// disposition instead of reaching the handler it inherited.
pid_t sleepingChild() {
  sigset_t term, previous;
  sigemptyset(&term);
  sigaddset(&term, SIGTERM);
  ::sigprocmask(SIG_BLOCK, &term, &previous);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::signal(SIGTERM, SIG_DFL);
    ::sigprocmask(SIG_SETMASK, &previous, nullptr);
    ::sleep(10);
    ::_exit(42);
  }
  ::sigprocmask(SIG_SETMASK, &previous, nullptr);
  return pid;
}

TEST(Interrupt, BeforeDeferringASignalEndsTheProcessByItsDefaultAction) {
  const int status = inChild([] {
    installInterruptHandlers();
    ::raise(SIGTERM);
    return 1;  // not reached
  });
  ASSERT_TRUE(WIFSIGNALED(status)) << "exit status " << WEXITSTATUS(status);
  EXPECT_EQ(WTERMSIG(status), SIGTERM);
}

TEST(Interrupt, AfterDeferringTheFirstSignalIsRecordedAndThrown) {
  const int status = inChild([] {
    installInterruptHandlers();
    if (interruptRequested() || interruptSignal() != 0) return 1;
    try {
      throwIfInterrupted();
    } catch (...) {
      return 2;
    }
    deferInterrupts();
    deferInterrupts();  // idempotent
    ::raise(SIGINT);
    if (!interruptRequested() || interruptSignal() != SIGINT) return 3;
    ::raise(SIGTERM);  // a second signal does not replace the first
    if (interruptSignal() != SIGINT) return 4;
    try {
      throwIfInterrupted();
      return 5;
    } catch (const Interrupted& e) {
      if (e.signal() != SIGINT) return 6;
      if (std::string(e.what()) != "interrupted by SIGINT") return 7;
    }
    return 0;
  });
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 0) << "check " << WEXITSTATUS(status) << " failed";
}

TEST(Interrupt, ASignalStartedIgnoredStaysIgnored) {
  const int status = inChild([] {
    ::signal(SIGHUP, SIG_IGN);  // as under nohup
    installInterruptHandlers();
    ::raise(SIGHUP);  // before deferring: would end the process if handled
    deferInterrupts();
    ::raise(SIGHUP);
    if (interruptRequested()) return 1;
    ::raise(SIGTERM);  // the others are still handled
    return interruptSignal() == SIGTERM ? 0 : 2;
  });
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 0) << "check " << WEXITSTATUS(status) << " failed";
}

TEST(Interrupt, RegisteredChildrenGetTheSignalForwardedUnregisteredOnesDoNot) {
  const int status = inChild([] {
    installInterruptHandlers();
    deferInterrupts();
    const pid_t forwarded = sleepingChild();
    const pid_t kept = sleepingChild();
    registerChild(forwarded);
    registerChild(kept);
    unregisterChild(kept);
    ::raise(SIGTERM);
    int child_status = 0;
    if (::waitpid(forwarded, &child_status, 0) != forwarded) return 1;
    if (!WIFSIGNALED(child_status) || WTERMSIG(child_status) != SIGTERM) return 2;
    // The unregistered child is still asleep: end it ourselves.
    if (::waitpid(kept, &child_status, WNOHANG) != 0) return 3;
    ::kill(kept, SIGKILL);
    ::waitpid(kept, &child_status, 0);
    unregisterChild(forwarded);
    return interruptSignal() == SIGTERM ? 0 : 4;
  });
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 0) << "check " << WEXITSTATUS(status) << " failed";
}

TEST(Interrupt, ABlockingReadReturnsWithEintrSoTheCallerSeesTheInterrupt) {
  int block[2], ready[2];
  ASSERT_EQ(::pipe(block), 0);
  ASSERT_EQ(::pipe(ready), 0);
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(block[1]);
    installInterruptHandlers();
    deferInterrupts();
    const char go = 1;
    if (::write(ready[1], &go, 1) != 1) ::_exit(3);
    char byte = 0;
    const ssize_t n = ::read(block[0], &byte, 1);  // nobody writes: blocks until a signal
    const int error = errno;
    if (n != -1 || error != EINTR) ::_exit(1);
    ::_exit(interruptSignal() == SIGINT ? 0 : 2);
  }
  char go = 0;
  ASSERT_EQ(::read(ready[0], &go, 1), 1);
  // The handlers are in place; a signal that lands before the child blocks in read() only
  // sets the flag, so keep signalling until it has returned from read().
  int status = 0;
  pid_t ended = 0;
  for (int attempt = 0; attempt < 100 && ended == 0; ++attempt) {
    ::kill(pid, SIGINT);
    ::usleep(50 * 1000);
    ended = ::waitpid(pid, &status, WNOHANG);
  }
  if (ended == 0) {
    ::kill(pid, SIGKILL);
    ::waitpid(pid, &status, 0);
    FAIL() << "the blocked read did not return after SIGINT";
  }
  for (int fd : {block[0], block[1], ready[0], ready[1]}) ::close(fd);
  ASSERT_TRUE(WIFEXITED(status)) << "ended by signal " << WTERMSIG(status);
  EXPECT_EQ(WEXITSTATUS(status), 0) << "check " << WEXITSTATUS(status) << " failed";
}

TEST(Interrupt, SignalNames) {
  EXPECT_EQ(signalName(SIGINT), "SIGINT");
  EXPECT_EQ(signalName(SIGTERM), "SIGTERM");
  EXPECT_EQ(signalName(SIGHUP), "SIGHUP");
  EXPECT_EQ(signalName(SIGKILL), "SIGKILL");
  EXPECT_EQ(signalName(SIGUSR1), "signal " + std::to_string(SIGUSR1));
}

}  // namespace
}  // namespace rollstep
