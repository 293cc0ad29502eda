#include "rollstep/common/gzip_text.hpp"

#include <zlib.h>

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <utility>

namespace rollstep {

namespace {
constexpr int kGzipWindowBits = 15 + 16;  // zlib's largest window, gzip wrapper
}

std::string gzipText(std::string_view text) {
  z_stream z{};
  if (deflateInit2(&z, Z_DEFAULT_COMPRESSION, Z_DEFLATED, kGzipWindowBits, 8, Z_DEFAULT_STRATEGY) !=
      Z_OK) {
    throw std::runtime_error("gzip: cannot start the compressor");
  }
  std::string out;
  out.resize(deflateBound(&z, static_cast<uLong>(text.size())));
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data()));
  z.avail_in = static_cast<uInt>(text.size());
  z.next_out = reinterpret_cast<Bytef*>(out.data());
  z.avail_out = static_cast<uInt>(out.size());
  // deflateBound's room: one call with Z_FINISH ends the stream.
  const int status =
      text.size() <= std::numeric_limits<uInt>::max() ? deflate(&z, Z_FINISH) : Z_BUF_ERROR;
  out.resize(z.total_out);
  deflateEnd(&z);
  if (status != Z_STREAM_END) throw std::runtime_error("gzip: compression failed");
  return out;
}

struct GzipFileWriter::Stream {
  z_stream z{};
};

GzipFileWriter::GzipFileWriter(std::string path)
    : file_(std::move(path)), stream_(std::make_unique<Stream>()) {
  if (deflateInit2(&stream_->z, Z_DEFAULT_COMPRESSION, Z_DEFLATED, kGzipWindowBits, 8,
                   Z_DEFAULT_STRATEGY) != Z_OK) {
    stream_.reset();
    throw OutputError("'" + file_.path() + "': cannot start the gzip compressor");
  }
}

GzipFileWriter::~GzipFileWriter() {
  if (stream_) deflateEnd(&stream_->z);
}

void GzipFileWriter::deflateInto(std::string_view text, bool finish) {
  if (!stream_) throw OutputError("'" + file_.path() + "': written after commit");
  z_stream& z = stream_->z;
  char chunk[1 << 16];
  std::size_t at = 0;
  int status = Z_OK;
  do {
    // zlib counts in uInt: long pieces in slices.
    const std::size_t slice = std::min<std::size_t>(text.size() - at, 1u << 30);
    z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(text.data() + at));
    z.avail_in = static_cast<uInt>(slice);
    const bool last = at + slice == text.size();
    do {
      z.next_out = reinterpret_cast<Bytef*>(chunk);
      z.avail_out = sizeof chunk;
      status = deflate(&z, finish && last ? Z_FINISH : Z_NO_FLUSH);
      if (status == Z_STREAM_ERROR) throw OutputError("'" + file_.path() + "': gzip failed");
      file_.write(std::string_view(chunk, sizeof chunk - z.avail_out));
    } while (z.avail_out == 0 || (finish && last && status != Z_STREAM_END));
    at += slice;
  } while (at < text.size());
}

void GzipFileWriter::write(std::string_view text) { deflateInto(text, false); }

void GzipFileWriter::commit() {
  deflateInto({}, true);
  deflateEnd(&stream_->z);
  stream_.reset();
  file_.commit();
}

std::string readGzipTextFile(const std::string& path, const std::string& what,
                             std::size_t max_bytes) {
  const std::string packed = readTextFile(path, what, max_bytes);
  const auto error = [&](const std::string& reason) {
    return InputError(what + " '" + path + "': " + reason);
  };
  if (packed.size() < 18 || static_cast<unsigned char>(packed[0]) != 0x1f ||
      static_cast<unsigned char>(packed[1]) != 0x8b) {
    throw error("not gzip data");
  }
  z_stream z{};
  if (inflateInit2(&z, kGzipWindowBits) != Z_OK) throw error("cannot start the decompressor");
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(packed.data()));
  z.avail_in = static_cast<uInt>(packed.size());
  std::string out;
  char chunk[1 << 16];
  int status = Z_OK;
  while (status == Z_OK) {
    z.next_out = reinterpret_cast<Bytef*>(chunk);
    z.avail_out = sizeof chunk;
    status = inflate(&z, Z_NO_FLUSH);
    if (status != Z_OK && status != Z_STREAM_END) break;
    out.append(chunk, sizeof chunk - z.avail_out);
    if (out.size() > max_bytes) {
      inflateEnd(&z);
      throw error("more than " + std::to_string(max_bytes) + " bytes once decompressed");
    }
    if (status == Z_OK && z.avail_in == 0 && z.avail_out != 0) status = Z_BUF_ERROR;
  }
  const bool trailing = z.avail_in != 0;
  inflateEnd(&z);
  if (status != Z_STREAM_END) throw error("truncated or corrupt gzip data");
  if (trailing) throw error("data after the end of the gzip stream");
  return out;
}

}  // namespace rollstep
