#pragma once
// Text outputs written gzip-compressed (RFC 1952, zlib) and read back: large logs whose
// users read them with standard tools (zcat, pandas.read_csv, numpy.loadtxt take .gz
// files as they are).
#include <cstddef>
#include <memory>
#include <string>
#include <string_view>

#include "rollstep/common/text_file.hpp"

namespace rollstep {

/// `text` as one gzip member (zlib's default level, no file name, time stamp 0: the same
/// text gives the same bytes). Throws std::runtime_error if zlib fails (out of memory).
std::string gzipText(std::string_view text);

/// An output written compressed as it comes, atomically (AtomicFileWriter: the file appears
/// complete on commit(), or not at all):
///   GzipFileWriter out("run/plan.csv.gz");
///   out.write(piece); ...; out.commit();
/// The bytes are gzipText's of all pieces together. Throws OutputError as AtomicFileWriter.
class GzipFileWriter {
 public:
  explicit GzipFileWriter(std::string path);
  ~GzipFileWriter();
  GzipFileWriter(const GzipFileWriter&) = delete;
  GzipFileWriter& operator=(const GzipFileWriter&) = delete;

  void write(std::string_view text);
  void commit();

 private:
  struct Stream;
  void deflateInto(std::string_view text, bool finish);
  AtomicFileWriter file_;
  std::unique_ptr<Stream> stream_;
};

/// The decompressed contents of the gzip file `path` (readTextFile's checks; `what` starts
/// every message). Throws InputError "<what> '<path>': <reason>" for a file that is not gzip
/// data, truncated or corrupt data, or more than `max_bytes` bytes once decompressed.
std::string readGzipTextFile(const std::string& path, const std::string& what,
                             std::size_t max_bytes = std::size_t{1} << 30);

}  // namespace rollstep
