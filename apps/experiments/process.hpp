#pragma once
// Child processes and facts about the machine and the build, for the report and the trials.
// Runs go to `rollstep sim` as child processes (this very program, /proc/self/exe): the
// report analyses only what a run wrote, and a run that crashes cannot take the report down.
#include <sys/types.h>

#include <functional>
#include <string>
#include <vector>

namespace rollstep::experiments {

/// This program's absolute path (/proc/self/exe).
std::string selfExecutable();

/// Shell-quoted command line (arguments with characters other than [A-Za-z0-9_./=:,+-] in
/// single quotes), for the report and --print-commands.
std::string shellCommand(const std::vector<std::string>& argv);

/// Starts `program` with `args` (not including argv[0]), standard input /dev/null, standard
/// output to the file `stdout_path`, standard error to `stderr_path` or, when
/// `stderr_pipe` is not null, into a pipe whose read end is stored there. Throws
/// std::runtime_error if the files or the process cannot be created. A program that cannot
/// be executed exits 127 with the reason on its standard error.
pid_t startProcess(const std::string& program, const std::vector<std::string>& args,
                   const std::string& stdout_path, const std::string& stderr_path,
                   int* stderr_pipe = nullptr);

/// Exit status of a finished child: its exit code, or 128 + the signal that killed it.
int exitStatusOf(int wait_status);

/// Runs a program to its end; every line of its standard error goes to `on_line` and to the
/// file `stderr_path`. Returns the exit status (exitStatusOf). The child gets this process's
/// interrupts (rollstep::registerChild) and is ended (SIGTERM, then SIGKILL a second later)
/// if it is still running a second after one. With a `time_limit` [s] > 0, a program still
/// running after it is ended the same way and `*timed_out` set.
int runProcess(const std::string& program, const std::vector<std::string>& args,
               const std::string& stdout_path, const std::string& stderr_path,
               const std::function<void(const std::string&)>& on_line, double time_limit = 0.0,
               bool* timed_out = nullptr);

/// Ends child `pid` (SIGTERM, then SIGKILL after `grace` seconds) and reaps it; returns its
/// wait status.
int endProcess(pid_t pid, double grace = 1.0);

/// The first line of `command`'s standard output (run with /bin/sh), or "" if it fails.
std::string commandOutput(const std::string& command);

/// "CPU model (N cores); SIMD: sse4_2 avx avx2 fma ..." from lscpu (or /proc/cpuinfo).
std::string machineDescription();

/// `git describe --always --dirty` of the source tree the program was built from, when it
/// is a git checkout; else "rollstep <version> (no git checkout)".
std::string versionDescription();

/// True if `name` is an executable in one of the PATH directories.
bool onPath(const std::string& name);

/// Progress on standard error: one line redrawn in place on a terminal, or a line per
/// step of at least 10 % otherwise.
class ProgressBar {
 public:
  explicit ProgressBar(std::string what);
  /// fraction in [0, 1]; `detail` shown after the bar.
  void update(double fraction, const std::string& detail);
  /// Ends the line (on a terminal).
  void finish(const std::string& detail);

 private:
  std::string what_;
  bool terminal_;
  int last_percent_ = -100;
  bool drawn_ = false;
};

}  // namespace rollstep::experiments
