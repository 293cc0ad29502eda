#include "rollstep/common/text_file.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdarg>
#include <cstdio>
#include <random>
#include <system_error>
#include <utility>

namespace rollstep {
namespace {

std::string errnoText(int error_number) {
  return std::error_code(error_number, std::generic_category()).message();
}

/// Why a stat result is not a regular file (empty if it is one).
std::string notRegularReason(const struct stat& st) {
  if (S_ISREG(st.st_mode)) return "";
  if (S_ISDIR(st.st_mode)) return "is a directory, not a regular file";
  if (S_ISFIFO(st.st_mode)) return "is a FIFO (named pipe), not a regular file";
  if (S_ISCHR(st.st_mode)) return "is a character device, not a regular file";
  if (S_ISBLK(st.st_mode)) return "is a block device, not a regular file";
  if (S_ISSOCK(st.st_mode)) return "is a socket, not a regular file";
  return "is not a regular file";
}

std::string tooLarge(unsigned long long size, std::size_t max_bytes) {
  return "is " + std::to_string(size) + " bytes, more than the limit of " +
         std::to_string(max_bytes) + " bytes";
}

struct FdCloser {
  int fd;
  ~FdCloser() {
    if (fd >= 0) ::close(fd);
  }
};

}  // namespace

std::string readTextFile(const std::string& path, const std::string& what, std::size_t max_bytes) {
  const auto error = [&](const std::string& reason) {
    return InputError(what + " '" + path + "': " + reason);
  };
  if (path.empty()) throw InputError(what + ": no file name given");
  // stat before open: opening a FIFO for reading would block until a writer appears.
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) throw error("cannot read: " + errnoText(errno));
  if (const std::string reason = notRegularReason(st); !reason.empty()) throw error(reason);
  if (static_cast<unsigned long long>(st.st_size) > max_bytes) {
    throw error(tooLarge(static_cast<unsigned long long>(st.st_size), max_bytes));
  }
  // O_NONBLOCK: should the path have been replaced by a FIFO since stat, open returns at
  // once and the fstat below refuses it. No effect on regular files.
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOCTTY | O_NONBLOCK);
  if (fd < 0) throw error("cannot open: " + errnoText(errno));
  const FdCloser closer{fd};
  if (::fstat(fd, &st) != 0) throw error("cannot read: " + errnoText(errno));
  if (const std::string reason = notRegularReason(st); !reason.empty()) throw error(reason);

  std::string contents;
  contents.reserve(static_cast<std::size_t>(st.st_size) <= max_bytes
                       ? static_cast<std::size_t>(st.st_size)
                       : max_bytes);
  char chunk[65536];
  for (;;) {
    const ssize_t n = ::read(fd, chunk, sizeof chunk);
    if (n < 0) {
      if (errno == EINTR) continue;
      throw error("read error: " + errnoText(errno));
    }
    if (n == 0) break;
    if (contents.size() + static_cast<std::size_t>(n) > max_bytes) {  // grew since stat
      throw error(tooLarge(contents.size() + static_cast<std::size_t>(n), max_bytes));
    }
    contents.append(chunk, static_cast<std::size_t>(n));
  }
  return contents;
}

// ---------------------------------------------------------------------------------------

namespace {
constexpr std::size_t kWriteBufferBytes = 64 * 1024;
}  // namespace

AtomicFileWriter::AtomicFileWriter(std::string path) : path_(std::move(path)) {
  if (path_.empty()) throw OutputError("output file: no file name given");
  const std::size_t slash = path_.rfind('/');
  const std::string prefix = slash == std::string::npos ? "" : path_.substr(0, slash + 1);
  const std::string dir = slash == std::string::npos ? "." : prefix;
  const std::string name = slash == std::string::npos ? path_ : path_.substr(slash + 1);
  if (name.empty() || name == "." || name == "..") {
    throw OutputError("cannot write '" + path_ + "': names a directory, not a file");
  }
  struct stat st {};
  if (::stat(path_.c_str(), &st) == 0) {
    if (const std::string reason = notRegularReason(st); !reason.empty()) {
      throw OutputError("cannot write '" + path_ + "': " + reason);
    }
  }
  // Our own unique name (not mkstemp) so that the file gets the usual 0666 & ~umask mode.
  static std::atomic<unsigned> counter{0};
  std::random_device entropy;
  for (int attempt = 0; attempt < 100; ++attempt) {
    char suffix[32];
    std::snprintf(suffix, sizeof suffix, ".tmp.%d.%08x", static_cast<int>(::getpid()),
                  entropy() ^ counter.fetch_add(1));
    std::string candidate = prefix + "." + name + suffix;
    fd_ = ::open(candidate.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC | O_NOCTTY, 0666);
    if (fd_ >= 0) {
      temp_path_ = std::move(candidate);
      buffer_.reserve(kWriteBufferBytes);
      return;
    }
    if (errno != EEXIST) {
      throw OutputError("cannot write '" + path_ + "': cannot create a file in '" + dir +
                        "': " + errnoText(errno));
    }
  }
  throw OutputError("cannot write '" + path_ + "': no free temporary name in '" + dir + "'");
}

AtomicFileWriter::~AtomicFileWriter() { discard(); }

AtomicFileWriter::AtomicFileWriter(AtomicFileWriter&& other) noexcept
    : path_(std::move(other.path_)),
      temp_path_(std::move(other.temp_path_)),
      buffer_(std::move(other.buffer_)),
      fd_(std::exchange(other.fd_, -1)),
      committed_(other.committed_) {
  other.temp_path_.clear();
}

AtomicFileWriter& AtomicFileWriter::operator=(AtomicFileWriter&& other) noexcept {
  if (this != &other) {
    discard();
    path_ = std::move(other.path_);
    temp_path_ = std::move(other.temp_path_);
    buffer_ = std::move(other.buffer_);
    fd_ = std::exchange(other.fd_, -1);
    committed_ = other.committed_;
    other.temp_path_.clear();
  }
  return *this;
}

void AtomicFileWriter::discard() noexcept {
  if (fd_ >= 0) {
    ::close(fd_);
    fd_ = -1;
  }
  if (!temp_path_.empty()) {
    ::unlink(temp_path_.c_str());
    temp_path_.clear();
  }
  buffer_.clear();
}

void AtomicFileWriter::fail(const std::string& action, int error_number) {
  discard();
  throw OutputError("cannot write '" + path_ + "': " + action + ": " + errnoText(error_number));
}

void AtomicFileWriter::flushBuffer() {
  std::size_t done = 0;
  while (done < buffer_.size()) {
    const ssize_t n = ::write(fd_, buffer_.data() + done, buffer_.size() - done);
    if (n < 0) {
      if (errno == EINTR) continue;
      fail("write failed", errno);
    }
    if (n == 0) fail("write failed", ENOSPC);
    done += static_cast<std::size_t>(n);
  }
  buffer_.clear();
}

void AtomicFileWriter::write(std::string_view bytes) {
  if (fd_ < 0) {
    throw OutputError("cannot write '" + path_ + "': the writer was " +
                      (committed_ ? "already committed" : "discarded after an error"));
  }
  if (buffer_.size() + bytes.size() > kWriteBufferBytes) {
    flushBuffer();
    if (bytes.size() >= kWriteBufferBytes) {  // large block: straight through
      buffer_.assign(bytes.data(), bytes.size());
      flushBuffer();
      return;
    }
  }
  buffer_.append(bytes.data(), bytes.size());
}

void AtomicFileWriter::printf(const char* format, ...) {
  char small[512];
  va_list args;
  va_start(args, format);
  va_list copy;
  va_copy(copy, args);
  const int n = std::vsnprintf(small, sizeof small, format, args);
  va_end(args);
  if (n < 0) {
    va_end(copy);
    fail("formatting failed", EINVAL);
  }
  if (static_cast<std::size_t>(n) < sizeof small) {
    va_end(copy);
    write(std::string_view(small, static_cast<std::size_t>(n)));
    return;
  }
  std::string large(static_cast<std::size_t>(n) + 1, '\0');
  std::vsnprintf(large.data(), large.size(), format, copy);
  va_end(copy);
  large.pop_back();
  write(large);
}

void AtomicFileWriter::commit() {
  if (fd_ < 0) write({});  // throws: already committed or failed
  flushBuffer();
  // fsync: the data is on disk before the rename makes it visible under the real name
  // (and delayed allocation errors such as a full disk surface here, not after exit).
  if (::fsync(fd_) != 0 && errno != EINVAL && errno != EROFS) fail("sync failed", errno);
  const int fd = std::exchange(fd_, -1);
  if (::close(fd) != 0) fail("close failed", errno);
  if (::rename(temp_path_.c_str(), path_.c_str()) != 0) fail("rename failed", errno);
  temp_path_.clear();
  committed_ = true;
}

void writeFileAtomically(const std::string& path, std::string_view contents) {
  AtomicFileWriter out(path);
  out.write(contents);
  out.commit();
}

}  // namespace rollstep
