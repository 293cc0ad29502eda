#pragma once
// The one rule for reading input files and writing output files, shared by every layer.
//
// Reading: readTextFile refuses, before opening anything, whatever is not a regular file
// (a directory, a FIFO, a device, a socket: so a FIFO never blocks the program), a missing
// or unreadable file, and a file larger than a limit; its messages name what the file is
// for, the path and the reason, e.g. "URDF file 'robot.urdf': is a directory".
//
// Writing: outputs never appear half-written. AtomicFileWriter writes a temporary file in
// the target's directory, checks every write, the flush to disk and the close (a full
// disk, a file size limit), and renames the temporary over the target only on commit();
// on any failure, or without commit(), the temporary is removed and the target is left
// as it was. writeFileAtomically is the one-shot form for small outputs.
#include <cstddef>
#include <stdexcept>
#include <string>
#include <string_view>

namespace rollstep {

/// An input file that cannot be used (missing, not a regular file, too large, unreadable).
class InputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// An output file that could not be written completely (its previous contents are kept).
class OutputError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

/// Exit status of a program ended by an OutputError (sysexits.h's EX_IOERR): the environment
/// failed (a full disk, no permission), not the experiment. `rollstep report` and `trials`
/// read it from their child runs and fail as a whole rather than record a failed run.
inline constexpr int kOutputErrorExitStatus = 74;

/// Default size limit of readTextFile: 64 MiB, far above any robot or configuration file.
constexpr std::size_t kDefaultMaxInputBytes = std::size_t{64} << 20;

/// The whole contents of the regular file `path`. `what` says what the file is for
/// ("URDF file", "solver settings", ...) and starts every error message. Throws InputError
/// "<what> '<path>': <reason>" for an empty path, a missing or unreadable file, anything
/// that is not a regular file (checked with stat before opening, and again on the open
/// descriptor), a file of more than max_bytes bytes and a read error.
std::string readTextFile(const std::string& path, const std::string& what,
                         std::size_t max_bytes = kDefaultMaxInputBytes);

/// Streaming atomic writer for large outputs (logs):
///   AtomicFileWriter out("run/log.csv");
///   out.write("t,x\n"); out.printf("%.3f,%.6f\n", t, x); ...
///   out.commit();  // log.csv appears complete, or an OutputError is thrown
/// Output is buffered; a failed write throws at the latest at commit(). Destroying a writer
/// that was not committed (an exception left the scope) removes the temporary. An existing
/// target that is not a regular file (a directory, a device) is refused at construction.
/// Not copyable; movable.
class AtomicFileWriter {
 public:
  /// Creates the temporary "<dir>/.<name>.tmp.XXXXXX". Throws OutputError naming the path and
  /// the system's reason (missing directory, permission, target not a regular file).
  explicit AtomicFileWriter(std::string path);
  ~AtomicFileWriter();
  AtomicFileWriter(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter& operator=(AtomicFileWriter&& other) noexcept;
  AtomicFileWriter(const AtomicFileWriter&) = delete;
  AtomicFileWriter& operator=(const AtomicFileWriter&) = delete;

  /// Appends bytes. Throws OutputError (and discards the temporary) if writing fails.
  void write(std::string_view bytes);
  /// Appends printf-formatted text (same checks as write).
  void printf(const char* format, ...) __attribute__((format(printf, 2, 3)));
  /// Flushes, syncs, closes and renames the temporary over the target. Throws OutputError
  /// naming the path and the reason on any failure (the temporary is removed, the target
  /// untouched). After commit() the writer is spent: write() and commit() throw.
  void commit();

  const std::string& path() const { return path_; }
  bool committed() const { return committed_; }

 private:
  void flushBuffer();
  [[noreturn]] void fail(const std::string& action, int error_number);
  void discard() noexcept;

  std::string path_;
  std::string temp_path_;
  std::string buffer_;
  int fd_ = -1;
  bool committed_ = false;
};

/// Writes `contents` to `path` atomically (AtomicFileWriter + commit). Throws OutputError
/// naming the path and the system's reason; the previous file, if any, is then unchanged.
void writeFileAtomically(const std::string& path, std::string_view contents);

}  // namespace rollstep
