#include "process.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <set>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "rollstep/common/interrupt.hpp"

namespace rollstep::experiments {

std::string selfExecutable() {
  char path[4096];
  const ssize_t n = ::readlink("/proc/self/exe", path, sizeof path - 1);
  if (n <= 0) throw std::runtime_error("cannot find this program's path (/proc/self/exe)");
  return std::string(path, static_cast<std::size_t>(n));
}

std::string shellCommand(const std::vector<std::string>& argv) {
  std::string out;
  for (const std::string& a : argv) {
    if (!out.empty()) out += ' ';
    const bool plain = !a.empty() && std::all_of(a.begin(), a.end(), [](char c) {
      return std::isalnum(static_cast<unsigned char>(c)) || std::strchr("_./=:,+-", c) != nullptr;
    });
    if (plain) {
      out += a;
    } else {
      out += '\'';
      for (char c : a) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
      out += '\'';
    }
  }
  return out;
}

pid_t startProcess(const std::string& program, const std::vector<std::string>& args,
                   const std::string& stdout_path, const std::string& stderr_path,
                   int* stderr_pipe) {
  const int out = ::open(stdout_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (out < 0) {
    throw std::runtime_error("cannot create '" + stdout_path + "': " + std::strerror(errno));
  }
  int err = -1;
  int pipe_fds[2] = {-1, -1};
  if (stderr_pipe != nullptr) {
    if (::pipe2(pipe_fds, O_CLOEXEC) != 0) {
      ::close(out);
      throw std::runtime_error(std::string("cannot create a pipe: ") + std::strerror(errno));
    }
    err = pipe_fds[1];
  } else {
    err = ::open(stderr_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (err < 0) {
      ::close(out);
      throw std::runtime_error("cannot create '" + stderr_path + "': " + std::strerror(errno));
    }
  }
  std::vector<std::string> argv_text{program};
  argv_text.insert(argv_text.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : argv_text) argv.push_back(a.data());
  argv.push_back(nullptr);
  std::fflush(nullptr);
  const pid_t pid = ::fork();
  if (pid == 0) {
    const int in = ::open("/dev/null", O_RDONLY);
    if (in >= 0) ::dup2(in, 0);
    ::dup2(out, 1);
    ::dup2(err, 2);
    ::execv(program.c_str(), argv.data());
    const std::string message = "cannot execute '" + program + "': " + std::strerror(errno) + "\n";
    (void)!::write(2, message.data(), message.size());
    ::_exit(127);
  }
  const int fork_errno = errno;
  ::close(out);
  ::close(err);
  if (pid < 0) {
    if (stderr_pipe != nullptr) ::close(pipe_fds[0]);
    throw std::runtime_error(std::string("cannot start a process: ") + std::strerror(fork_errno));
  }
  if (stderr_pipe != nullptr) *stderr_pipe = pipe_fds[0];
  return pid;
}

int exitStatusOf(int wait_status) {
  if (WIFEXITED(wait_status)) return WEXITSTATUS(wait_status);
  if (WIFSIGNALED(wait_status)) return 128 + WTERMSIG(wait_status);
  return 255;
}

int endProcess(pid_t pid, double grace) {
  ::kill(pid, SIGTERM);
  int status = 0;
  const auto until = std::chrono::steady_clock::now() + std::chrono::duration<double>(grace);
  for (;;) {
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid || (r < 0 && errno != EINTR)) return status;
    if (std::chrono::steady_clock::now() >= until) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ::kill(pid, SIGKILL);
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return status;
}

int runProcess(const std::string& program, const std::vector<std::string>& args,
               const std::string& stdout_path, const std::string& stderr_path,
               const std::function<void(const std::string&)>& on_line, double time_limit,
               bool* timed_out) {
  std::ofstream log(stderr_path);
  int fd = -1;
  const pid_t pid = startProcess(program, args, stdout_path, stderr_path, &fd);
  registerChild(pid);
  if (timed_out != nullptr) *timed_out = false;
  using Clock = std::chrono::steady_clock;
  const Clock::time_point deadline =
      Clock::now() + std::chrono::duration_cast<Clock::duration>(
                         std::chrono::duration<double>(time_limit > 0.0 ? time_limit : 0.0));
  // The child got this process's interrupt (forwarded): it has a second to end on its own.
  Clock::time_point interrupted_until = Clock::time_point::max();
  // Milliseconds to wait for the child at most, -1 for no limit; 0: end it now.
  const auto wait_ms = [&]() -> int {
    const Clock::time_point now = Clock::now();
    if (interruptRequested() && interrupted_until == Clock::time_point::max()) {
      interrupted_until = now + std::chrono::seconds(1);
    }
    Clock::time_point until = interrupted_until;
    if (time_limit > 0.0) until = std::min(until, deadline);
    if (until == Clock::time_point::max()) return -1;
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(until - now).count();
    return left > 0 ? static_cast<int>(std::min<long long>(left, 1000000)) : 0;
  };
  bool give_up = false;
  std::string pending;
  char buffer[4096];
  while (true) {
    struct pollfd p {
      fd, POLLIN, 0
    };
    const int ready = ::poll(&p, 1, wait_ms());
    if (ready < 0 && errno == EINTR) continue;  // an interrupt: forwarded to the child
    if (ready == 0) {
      give_up = true;
      break;
    }
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    pending.append(buffer, static_cast<std::size_t>(n));
    std::size_t nl;
    while ((nl = pending.find('\n')) != std::string::npos) {
      const std::string line = pending.substr(0, nl);
      pending.erase(0, nl + 1);
      log << line << '\n';
      if (on_line) on_line(line);
    }
  }
  if (!pending.empty()) {
    log << pending << '\n';
    if (on_line) on_line(pending);
  }
  ::close(fd);
  int status = 0;
  for (;;) {  // its standard error closed: wait for its end, within the same limits
    if (give_up) {
      status = endProcess(pid);
      break;
    }
    const pid_t r = ::waitpid(pid, &status, WNOHANG);
    if (r == pid) break;
    if (r < 0 && errno != EINTR) break;
    if (r == 0) {
      if (wait_ms() == 0) {
        give_up = true;
        continue;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  const bool expired = give_up && time_limit > 0.0 && Clock::now() >= deadline;
  unregisterChild(pid);
  if (timed_out != nullptr) *timed_out = expired;
  return exitStatusOf(status);
}

std::string commandOutput(const std::string& command) {
  FILE* p = ::popen(("(" + command + ") 2>/dev/null").c_str(), "r");
  if (p == nullptr) return "";
  std::string out;
  char buffer[4096];
  while (std::fgets(buffer, sizeof buffer, p) != nullptr) out += buffer;
  const int status = ::pclose(p);
  if (status != 0) return "";
  const std::size_t nl = out.find('\n');
  return nl == std::string::npos ? out : out.substr(0, nl);
}

std::string machineDescription() {
  static const std::string description = [] {
    std::string model, flags;
    int cpus = 0;
    std::ifstream cpuinfo("/proc/cpuinfo");
    std::string line;
    while (std::getline(cpuinfo, line)) {
      const std::size_t colon = line.find(':');
      if (colon == std::string::npos) continue;
      std::string key = line.substr(0, colon);
      key.erase(key.find_last_not_of(" \t") + 1);
      const std::string value = colon + 2 <= line.size() ? line.substr(colon + 2) : "";
      if (key == "model name" && model.empty()) model = value;
      if (key == "flags" && flags.empty()) flags = value;
      if (key == "processor") ++cpus;
    }
    // lscpu is what the project's performance notes quote; /proc/cpuinfo is the fallback.
    const std::string lscpu = commandOutput("lscpu | sed -n 's/^Model name: *//p'");
    if (!lscpu.empty()) model = lscpu;
    static const char* const kSimd[] = {
        "sse2",    "sse3",     "ssse3",    "sse4_1",   "sse4_2",      "avx",  "avx2", "fma",
        "avx512f", "avx512dq", "avx512bw", "avx512vl", "avx512_vnni", "neon", "asimd"};
    std::set<std::string> have;
    std::istringstream words(flags);
    std::string w;
    while (words >> w) have.insert(w);
    std::string simd;
    for (const char* s : kSimd) {
      if (have.count(s) != 0) simd += (simd.empty() ? "" : " ") + std::string(s);
    }
    if (model.empty()) model = "unknown CPU";
    return model + " (" + std::to_string(cpus) +
           " logical CPUs); SIMD: " + (simd.empty() ? "none found" : simd);
  }();
  return description;
}

std::string versionDescription() {
#ifdef ROLLSTEP_SOURCE_DIR
  const std::string describe =
      commandOutput("git -C '" + std::string(ROLLSTEP_SOURCE_DIR) + "' describe --always --dirty");
  if (!describe.empty()) return "git " + describe + " (rollstep " ROLLSTEP_VERSION ")";
#endif
  return "rollstep " ROLLSTEP_VERSION " (no git checkout)";
}

bool onPath(const std::string& name) {
  const char* path = std::getenv("PATH");
  if (path == nullptr) return false;
  std::istringstream dirs(path);
  std::string dir;
  while (std::getline(dirs, dir, ':')) {
    if (dir.empty()) continue;
    const std::string file = dir + "/" + name;
    struct stat st {};
    if (::stat(file.c_str(), &st) == 0 && S_ISREG(st.st_mode) &&
        ::access(file.c_str(), X_OK) == 0) {
      return true;
    }
  }
  return false;
}

ProgressBar::ProgressBar(std::string what) : what_(std::move(what)), terminal_(::isatty(2) != 0) {}

void ProgressBar::update(double fraction, const std::string& detail) {
  fraction = std::max(0.0, std::min(1.0, fraction));
  const int percent = static_cast<int>(std::floor(100.0 * fraction));
  if (terminal_) {
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(std::lround(kWidth * fraction));
    std::fprintf(stderr, "\r\033[K%s [%s%s] %3d %% %s", what_.c_str(),
                 std::string(static_cast<std::size_t>(filled), '#').c_str(),
                 std::string(static_cast<std::size_t>(kWidth - filled), '.').c_str(), percent,
                 detail.c_str());
    drawn_ = true;
  } else if (percent >= last_percent_ + 10 || (percent == 100 && last_percent_ != 100)) {
    std::fprintf(stderr, "%s: %3d %% %s\n", what_.c_str(), percent, detail.c_str());
    last_percent_ = percent;
  }
  std::fflush(stderr);
}

void ProgressBar::finish(const std::string& detail) {
  update(1.0, detail);
  if (terminal_ && drawn_) std::fputc('\n', stderr);
  std::fflush(stderr);
}

}  // namespace rollstep::experiments
