// The shared file rule: readTextFile refuses everything but a readable regular file within
// its size limit, before blocking on anything; AtomicFileWriter never leaves a partial file.
#include "rollstep/common/text_file.hpp"

#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace rollstep {
namespace {

namespace fs = std::filesystem;

/// A fresh temporary directory, removed with its contents at the end of the test.
class TempDir {
 public:
  TempDir() {
    std::string tmpl = (fs::temp_directory_path() / "rollstep_common_XXXXXX").string();
    if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    path_ = tmpl;
  }
  ~TempDir() {
    std::error_code ec;
    fs::permissions(path_, fs::perms::owner_all, fs::perm_options::add, ec);
    fs::remove_all(path_, ec);
  }
  std::string file(const std::string& name) const { return (path_ / name).string(); }
  std::vector<std::string> entries() const {
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(path_)) names.push_back(e.path().filename());
    return names;
  }
  const fs::path& path() const { return path_; }

 private:
  fs::path path_;
};

void writePlain(const std::string& path, const std::string& contents) {
  std::ofstream out(path, std::ios::binary);
  out << contents;
}

std::string readPlain(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

/// The message of the InputError readTextFile throws ("" if it does not throw).
std::string readError(const std::string& path, std::size_t max_bytes = kDefaultMaxInputBytes) {
  try {
    readTextFile(path, "test input", max_bytes);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

bool contains(const std::string& text, const std::string& part) {
  return text.find(part) != std::string::npos;
}

TEST(ReadTextFile, ReadsARegularFileExactly) {
  TempDir dir;
  const std::string binary("line 1\r\n\0 nul inside\n no final newline", 38);
  writePlain(dir.file("a.txt"), binary);
  EXPECT_EQ(readTextFile(dir.file("a.txt"), "test input"), binary);
  writePlain(dir.file("empty"), "");
  EXPECT_EQ(readTextFile(dir.file("empty"), "test input"), "");
  // Larger than one read chunk.
  std::string big(300000, 'x');
  for (std::size_t i = 0; i < big.size(); i += 7) big[i] = static_cast<char>('a' + i % 26);
  writePlain(dir.file("big"), big);
  EXPECT_EQ(readTextFile(dir.file("big"), "test input"), big);
  // A symbolic link to a regular file is that file.
  fs::create_symlink(dir.file("a.txt"), dir.file("link"));
  EXPECT_EQ(readTextFile(dir.file("link"), "test input"), binary);
}

TEST(ReadTextFile, MessagesNameWhatThePathAndTheReason) {
  TempDir dir;
  const std::string missing = dir.file("missing.yaml");
  std::string e = readError(missing);
  EXPECT_TRUE(contains(e, "test input '" + missing + "'") && contains(e, "No such file")) << e;
  try {
    readTextFile("", "URDF file");
    ADD_FAILURE() << "empty path accepted";
  } catch (const InputError& err) {
    EXPECT_TRUE(contains(err.what(), "URDF file") && contains(err.what(), "no file name"))
        << err.what();
  }
  // A file inside a regular file: not a directory.
  writePlain(dir.file("plain"), "x");
  e = readError(dir.file("plain") + "/inner");
  EXPECT_TRUE(contains(e, "Not a directory")) << e;
  // InputError is a std::runtime_error for callers that catch those.
  EXPECT_THROW(readTextFile(missing, "x"), std::runtime_error);
}

TEST(ReadTextFile, RefusesWhatIsNotARegularFile) {
  TempDir dir;
  std::string e = readError(dir.path().string());
  EXPECT_TRUE(contains(e, "is a directory")) << e;
  e = readError("/dev/null");
  EXPECT_TRUE(contains(e, "'/dev/null'") && contains(e, "character device")) << e;
  // A FIFO with no writer: opening it would block forever; it must be refused at once.
  ASSERT_EQ(::mkfifo(dir.file("fifo").c_str(), 0600), 0);
  e = readError(dir.file("fifo"));
  EXPECT_TRUE(contains(e, "FIFO")) << e;
  // A symbolic link to a FIFO is refused too (stat follows it).
  fs::create_symlink(dir.file("fifo"), dir.file("fifo_link"));
  e = readError(dir.file("fifo_link"));
  EXPECT_TRUE(contains(e, "FIFO")) << e;
  // A Unix socket.
  const int s = ::socket(AF_UNIX, SOCK_STREAM, 0);
  ASSERT_GE(s, 0);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  const std::string sock = dir.file("sock");
  if (sock.size() < sizeof addr.sun_path) {
    std::strncpy(addr.sun_path, sock.c_str(), sizeof addr.sun_path - 1);
    ASSERT_EQ(::bind(s, reinterpret_cast<sockaddr*>(&addr), sizeof addr), 0);
    e = readError(sock);
    EXPECT_TRUE(contains(e, "socket")) << e;
  }
  ::close(s);
}

TEST(ReadTextFile, RefusesFilesAboveTheLimit) {
  TempDir dir;
  writePlain(dir.file("f"), std::string(100, 'a'));
  EXPECT_EQ(readTextFile(dir.file("f"), "x", 100).size(), 100u);
  const std::string e = readError(dir.file("f"), 99);
  EXPECT_TRUE(contains(e, "100 bytes") && contains(e, "limit of 99 bytes")) << e;
}

TEST(ReadTextFile, RefusesAnUnreadableFile) {
  if (::geteuid() == 0) GTEST_SKIP() << "root reads every file";
  TempDir dir;
  writePlain(dir.file("secret"), "x");
  ASSERT_EQ(::chmod(dir.file("secret").c_str(), 0), 0);
  const std::string e = readError(dir.file("secret"));
  EXPECT_TRUE(contains(e, "Permission denied")) << e;
}

std::string writeError(const std::string& path, const std::string& contents) {
  try {
    writeFileAtomically(path, contents);
  } catch (const OutputError& e) {
    return e.what();
  }
  return "";
}

TEST(WriteFileAtomically, WritesAndReplacesLeavingNoTemporary) {
  TempDir dir;
  const std::string target = dir.file("out.txt");
  writeFileAtomically(target, "first\n");
  EXPECT_EQ(readPlain(target), "first\n");
  const std::string binary("a\0b", 3);
  writeFileAtomically(target, binary);
  EXPECT_EQ(readPlain(target), binary);
  writeFileAtomically(target, "");
  EXPECT_EQ(readPlain(target), "");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"out.txt"});
  // Usual permissions (0666 & ~umask), not mkstemp's 0600.
  const mode_t mask = ::umask(022);
  ::umask(mask);
  writeFileAtomically(dir.file("mode"), "x");
  struct stat st {};
  ASSERT_EQ(::stat(dir.file("mode").c_str(), &st), 0);
  EXPECT_EQ(st.st_mode & 0777, 0666 & ~mask);
}

TEST(WriteFileAtomically, RefusesBadTargetsNamingPathAndReason) {
  TempDir dir;
  const std::string nodir = dir.file("no/such/dir/out.txt");
  std::string e = writeError(nodir, "x");
  EXPECT_TRUE(contains(e, "'" + nodir + "'") && contains(e, "No such file or directory")) << e;
  e = writeError(dir.path().string(), "x");
  EXPECT_TRUE(contains(e, "is a directory")) << e;
  e = writeError(dir.path().string() + "/", "x");
  EXPECT_TRUE(contains(e, "directory")) << e;
  // Never replace a device by a regular file.
  e = writeError("/dev/full", "x");
  EXPECT_TRUE(contains(e, "'/dev/full'") && contains(e, "character device")) << e;
  e = writeError("", "x");
  EXPECT_TRUE(contains(e, "no file name")) << e;
  EXPECT_TRUE(dir.entries().empty());
  if (::geteuid() != 0) {  // root writes into read-only directories
    ASSERT_EQ(::mkdir(dir.file("ro").c_str(), 0500), 0);
    e = writeError(dir.file("ro/out.txt"), "x");
    EXPECT_TRUE(contains(e, "Permission denied")) << e;
  }
}

/// Lowers the file size limit (a stand-in for a full disk: write() fails with EFBIG after
/// `bytes`) for the lifetime of the object. SIGXFSZ is ignored so the write fails instead.
class FileSizeLimit {
 public:
  explicit FileSizeLimit(rlim_t bytes) {
    ::getrlimit(RLIMIT_FSIZE, &old_);
    old_handler_ = ::signal(SIGXFSZ, SIG_IGN);
    rlimit lim = old_;
    lim.rlim_cur = bytes;
    ok_ = ::setrlimit(RLIMIT_FSIZE, &lim) == 0;
  }
  ~FileSizeLimit() {
    ::setrlimit(RLIMIT_FSIZE, &old_);
    ::signal(SIGXFSZ, old_handler_);
  }
  bool ok() const { return ok_; }

 private:
  rlimit old_{};
  sighandler_t old_handler_ = SIG_DFL;
  bool ok_ = false;
};

TEST(WriteFileAtomically, AFailedWriteKeepsTheOldFileAndRemovesTheTemporary) {
  TempDir dir;
  const std::string target = dir.file("summary.txt");
  writePlain(target, "old contents\n");
  std::string e;
  {
    FileSizeLimit limit(1000);
    ASSERT_TRUE(limit.ok());
    e = writeError(target, std::string(5000, 'y'));
  }
  EXPECT_TRUE(contains(e, "'" + target + "'") && contains(e, "File too large")) << e;
  EXPECT_EQ(readPlain(target), "old contents\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"summary.txt"});
}

TEST(AtomicFileWriter, StreamsLargeOutputAndAppearsOnlyOnCommit) {
  TempDir dir;
  const std::string target = dir.file("log.csv");
  std::string expected;
  {
    AtomicFileWriter out(target);
    EXPECT_EQ(out.path(), target);
    out.write("t,x\n");
    expected += "t,x\n";
    for (int i = 0; i < 200000; ++i) {
      out.printf("%d,%.6f\n", i, 0.5 * i);
      char line[64];
      std::snprintf(line, sizeof line, "%d,%.6f\n", i, 0.5 * i);
      expected += line;
    }
    const std::string block(200000, 'z');  // larger than the buffer: written straight through
    out.write(block);
    expected += block;
    const std::string wide(3000, 'w');  // printf output longer than its stack buffer
    out.printf("%s|\n", wide.c_str());
    expected += wide + "|\n";
    EXPECT_FALSE(fs::exists(target));  // not before commit
    EXPECT_EQ(dir.entries().size(), 1u);
    out.commit();
    EXPECT_TRUE(out.committed());
    EXPECT_THROW(out.write("late"), OutputError);
    EXPECT_THROW(out.commit(), OutputError);
  }
  EXPECT_EQ(readPlain(target), expected);
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"log.csv"});
}

TEST(AtomicFileWriter, WithoutCommitNothingIsLeft) {
  TempDir dir;
  const std::string target = dir.file("log.csv");
  writePlain(target, "previous run\n");
  try {
    AtomicFileWriter out(target);
    out.write("partial");
    throw std::runtime_error("simulation diverged");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(readPlain(target), "previous run\n");
  EXPECT_EQ(dir.entries(), std::vector<std::string>{"log.csv"});
  // Moving hands the temporary over; the moved-from writer removes nothing on destruction.
  AtomicFileWriter a(dir.file("moved.txt"));
  a.write("moved ");
  AtomicFileWriter b(std::move(a));
  b.write("ok");
  AtomicFileWriter c(dir.file("other.txt"));
  c = std::move(b);  // c's own temporary (other.txt) is discarded
  c.commit();
  EXPECT_EQ(readPlain(dir.file("moved.txt")), "moved ok");
  EXPECT_FALSE(fs::exists(dir.file("other.txt")));
  EXPECT_EQ(dir.entries().size(), 2u);
}

TEST(AtomicFileWriter, AWriteErrorWhileStreamingThrowsAndDiscards) {
  TempDir dir;
  const std::string target = dir.file("log.csv");
  std::string e;
  {
    FileSizeLimit limit(100000);
    ASSERT_TRUE(limit.ok());
    try {
      AtomicFileWriter out(target);
      for (int i = 0; i < 100000; ++i) out.printf("%d,%d\n", i, i);  // ~1 MB
      out.commit();
    } catch (const OutputError& err) {
      e = err.what();
    }
  }
  EXPECT_TRUE(contains(e, "'" + target + "'") && contains(e, "File too large")) << e;
  EXPECT_FALSE(fs::exists(target));
  EXPECT_TRUE(dir.entries().empty());
  // A write after the failure is refused, not silently dropped.
  {
    FileSizeLimit limit(10);
    AtomicFileWriter out(target);
    out.write(std::string(100, 'a'));  // buffered: the failure shows at commit
    EXPECT_THROW(out.commit(), OutputError);
    EXPECT_THROW(out.write("more"), OutputError);
  }
  EXPECT_TRUE(dir.entries().empty());
}

}  // namespace
}  // namespace rollstep
