#pragma once
// Interrupts (SIGINT, SIGTERM, SIGHUP) for programs that write outputs.
//
// installInterruptHandlers() at the start of main. Until a command has outputs to clean up,
// an interrupt ends the process at once, by the signal's own default action (nothing has
// been written yet, so nothing is left behind). Once it calls deferInterrupts() (just
// before it touches its outputs), an interrupt only sets a flag: the command's loops ask
// interruptRequested() or call throwIfInterrupted(), which throws Interrupted, and the
// command removes its temporary files and writes FAILED on the way out.
//
// Child processes registered with registerChild() get every interrupt this process gets
// (forwarded from the handler with kill(2)), so that `kill <pid>` of a parent ends its
// runs too and each run cleans up after itself.
#include <sys/types.h>

#include <stdexcept>
#include <string>

namespace rollstep {

/// A run ended by SIGINT, SIGTERM or SIGHUP; signal() is the signal's number.
class Interrupted : public std::runtime_error {
 public:
  explicit Interrupted(int signal_number);
  int signal() const { return signal_; }

 private:
  int signal_;
};

/// Installs the handlers of SIGINT, SIGTERM and SIGHUP (without SA_RESTART: a blocking
/// read or wait returns EINTR, so the caller sees the interrupt at once). A signal the
/// process was started ignoring (nohup's SIGHUP, SIGINT in a script's background job) stays
/// ignored.
void installInterruptHandlers();

/// From now on an interrupt sets the flag instead of ending the process. Idempotent.
void deferInterrupts() noexcept;

/// Whether an interrupt arrived (since deferInterrupts or before); async-signal-safe.
bool interruptRequested() noexcept;

/// The signal of the first interrupt, 0 if none.
int interruptSignal() noexcept;

/// Throws Interrupted if an interrupt arrived.
void throwIfInterrupted();

/// "SIGINT", "SIGTERM", "SIGHUP", "SIGKILL", else "signal N".
std::string signalName(int signal_number);

/// Child processes that get the interrupts forwarded (at most 512 at once; more are not
/// forwarded). Safe to call from any thread.
void registerChild(pid_t pid) noexcept;
void unregisterChild(pid_t pid) noexcept;

}  // namespace rollstep
