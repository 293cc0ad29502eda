// gzip-compressed text outputs: what is written in pieces reads back whole, is the same
// bytes as one gzipText of the whole, and is real gzip (gunzip reads it); bad data is
// refused naming the file and the reason.
#include "rollstep/common/gzip_text.hpp"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

namespace rollstep {
namespace {

namespace fs = std::filesystem;

std::string someCsv(int rows) {
  std::string text = "time[s],x[m]\n";
  for (int r = 0; r < rows; ++r) {
    text += std::to_string(r * 0.001) + "," + std::to_string((r * 7919) % 1000 - 500) + "\n";
  }
  return text;
}

class GzipText : public ::testing::Test {
 protected:
  void SetUp() override {
    std::string tmpl = (fs::temp_directory_path() / "rollstep_gzip_XXXXXX").string();
    ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
    dir_ = tmpl;
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string file(const std::string& name) const { return (dir_ / name).string(); }
  static std::string bytesOf(const std::string& path) { return readTextFile(path, "test file"); }
  fs::path dir_;
};

TEST_F(GzipText, PiecesWrittenReadBackWholeAndMatchOneCompression) {
  const std::string text = someCsv(40000);  // about 0.5 MB: several output chunks
  const std::string path = file("plan.csv.gz");
  {
    GzipFileWriter out(path);
    for (std::size_t at = 0; at < text.size(); at += 9973) out.write(text.substr(at, 9973));
    EXPECT_FALSE(fs::exists(path)) << "appears only on commit";
    out.commit();
  }
  const std::string packed = bytesOf(path);
  EXPECT_LT(packed.size(), text.size() / 3);
  EXPECT_EQ(packed, gzipText(text));
  EXPECT_EQ(readGzipTextFile(path, "plan"), text);
  // The standard tool reads it (gzip is a dependency of Debian's base system).
  const std::string plain = file("plain.csv");
  ASSERT_EQ(std::system(("gzip -dc '" + path + "' > '" + plain + "'").c_str()), 0);
  EXPECT_EQ(bytesOf(plain), text);
}

TEST_F(GzipText, EmptyTextAndUncommittedWriter) {
  const std::string path = file("empty.gz");
  {
    GzipFileWriter out(path);
    out.commit();
  }
  EXPECT_EQ(readGzipTextFile(path, "plan"), "");
  {
    GzipFileWriter out(file("dropped.gz"));
    out.write("abc");
  }                 // an exception left the scope: nothing written
  int entries = 0;  // empty.gz only: no temporary left either
  for (const fs::directory_entry& e : fs::directory_iterator(dir_)) {
    ++entries;
    EXPECT_EQ(e.path().filename(), "empty.gz");
  }
  EXPECT_EQ(entries, 1);
}

TEST_F(GzipText, BadDataIsRefusedNamingTheFile) {
  const std::string packed = gzipText(someCsv(2000));
  const auto expectRefused = [&](const std::string& name, const std::string& bytes,
                                 const std::string& reason, std::size_t limit = 1 << 30) {
    const std::string path = file(name);
    std::ofstream(path, std::ios::binary) << bytes;
    try {
      readGzipTextFile(path, "plan", limit);
      ADD_FAILURE() << name << " was read";
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find("plan '" + path + "': " + reason), std::string::npos)
          << e.what();
    }
  };
  expectRefused("plain.csv.gz", someCsv(10), "not gzip data");
  expectRefused("truncated.gz", packed.substr(0, packed.size() / 2),
                "truncated or corrupt gzip data");
  std::string corrupt = packed;
  corrupt[corrupt.size() / 2] = static_cast<char>(corrupt[corrupt.size() / 2] ^ 0x55);
  expectRefused("corrupt.gz", corrupt, "truncated or corrupt gzip data");
  expectRefused("trailing.gz", packed + "xyz", "data after the end of the gzip stream");
  // 1 MB of one letter packs into about a kB: the limit holds for the decompressed text.
  const std::string bomb = gzipText(std::string(1 << 20, 'a'));
  ASSERT_LT(bomb.size(), 2000u);
  expectRefused("bomb.gz", bomb, "more than 100000 bytes once decompressed", 100000);
  try {
    readGzipTextFile(file("missing.gz"), "plan");
    ADD_FAILURE() << "a missing file was read";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("missing.gz"), std::string::npos);
  }
}

}  // namespace
}  // namespace rollstep
