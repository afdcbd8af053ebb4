#include "pslam/core/GzipStream.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <vector>

#include <zlib.h>

#include "pslam/core/Error.h"

namespace fs = std::filesystem;

namespace pslam {

namespace {
gzFile gz(void* f) { return static_cast<gzFile>(f); }
}  // namespace

GzipInputStream::GzipInputStream(fs::path path) : path_(std::move(path)) {
  std::error_code ec;
  if (!fs::is_regular_file(path_, ec)) throw Error(path_.string() + ": file not found");
  fileSize_ = fs::file_size(path_, ec);
  file_ = gzopen(path_.c_str(), "rb");
  if (!file_) throw Error(path_.string() + ": cannot open (" + std::strerror(errno) + ")");
  gzbuffer(gz(file_), 128 * 1024);
  compressed_ = gzdirect(gz(file_)) == 0;
}

GzipInputStream::~GzipInputStream() {
  if (file_) gzclose(gz(file_));
}

void GzipInputStream::fail() {
  int err = Z_OK;
  std::string msg = gzerror(gz(file_), &err);
  // zlib prefixes its message with the file name given to gzopen.
  const std::string prefix = path_.string() + ": ";
  if (msg.rfind(prefix, 0) == 0) msg = msg.substr(prefix.size());
  const long long offset = static_cast<long long>(gzoffset(gz(file_)));
  if (err == Z_BUF_ERROR)
    failure_ = "truncated: the gzip data ends at byte " + std::to_string(fileSize_) + " before the end of its stream";
  else if (err == Z_ERRNO)
    failure_ = std::string("read error (") + std::strerror(errno) + ")";
  else
    // A CRC-32 or length mismatch is found at the end of the stream, a broken deflate code where it is.
    failure_ = "corrupt gzip data (zlib: " + (msg.empty() ? std::string("error ") + std::to_string(err) : msg) +
               ", found at compressed byte " + std::to_string(std::max(0LL, offset)) + ")";
  throw Error(path_.string() + ": " + failure_);
}

size_t GzipInputStream::Read(void* buffer, size_t count) {
  if (!failure_.empty()) throw Error(path_.string() + ": " + failure_);
  auto* out = static_cast<unsigned char*>(buffer);
  size_t total = 0;
  while (total < count && !atEnd_) {
    const unsigned want = static_cast<unsigned>(std::min<size_t>(count - total, 1u << 30));
    const int got = gzread(gz(file_), out + total, want);
    if (got < 0) fail();
    total += static_cast<size_t>(got);
    if (static_cast<unsigned>(got) < want) {
      // Less than asked for: the end of the input, or an error zlib reports only through gzerror
      // (Z_BUF_ERROR: the file ends inside the gzip stream).
      int err = Z_OK;
      gzerror(gz(file_), &err);
      if (err != Z_OK || !gzeof(gz(file_))) fail();
      atEnd_ = true;
    }
  }
  position_ += total;
  return total;
}

size_t GzipInputStream::Write(const void*, size_t) { throw Error(path_.string() + ": opened for reading only"); }

uint64_t GzipInputStream::Seek(int64_t, TSeekOrigin) { throw Error(path_.string() + ": the stream is not seekable"); }

uint64_t GzipInputStream::getTotalBytesCount() const { return fileSize_; }

uint64_t GzipInputStream::getPosition() const { return position_; }

std::string GzipInputStream::getStreamDescription() const { return "GzipInputStream: " + path_.string(); }

void verifyGzipFile(const fs::path& path) {
  GzipInputStream in(path);
  if (!in.compressed()) return;
  std::vector<char> buffer(256 * 1024);
  while (in.Read(buffer.data(), buffer.size()) == buffer.size()) {
  }
}

void GzipInputStream::requireEnd() {
  unsigned char byte = 0;
  if (Read(&byte, 1) != 0)
    throw Error(path_.string() + ": unexpected data after the end (at byte " + std::to_string(position_ - 1) + ")");
}

void throwArchiveReadError(const std::filesystem::path& path, const std::exception& e, const GzipInputStream& stream,
                           const std::string& contentFailure, const std::string& fileKind) {
  if (!stream.failure().empty()) throw Error(path.string() + ": " + stream.failure());
  if (!contentFailure.empty()) throw Error(path.string() + ": " + contentFailure);
  // Another MRPT object: a class this program knows ("Stored: <class>") or not ("has class '<class>'").
  const std::string what = e.what();
  std::string cls;
  if (const auto at = what.find("Stored: "); at != std::string::npos)
    cls = what.substr(at + 8, what.find_first_of("\n ", at + 8) - at - 8);
  else if (const auto at2 = what.find("has class '"); at2 != std::string::npos)
    cls = what.substr(at2 + 11, what.find('\'', at2 + 11) - at2 - 11);
  if (!cls.empty()) throw Error(path.string() + ": not a " + fileKind + " (it holds a " + cls + ")");
  if (const auto* err = dynamic_cast<const Error*>(&e)) throw *err;
  throw Error(path.string() + ": not a readable " + fileKind + " (truncated or corrupt: " + oneLineMessage(e) + ")");
}

}  // namespace pslam
