#include "pslam/core/GzipStream.h"

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <deque>
#include <fstream>
#include <future>
#include <string>
#include <utility>
#include <vector>

#include <zlib.h>

#include "pslam/core/Error.h"

namespace fs = std::filesystem;

namespace pslam {

namespace {
gzFile gz(void* f) { return static_cast<gzFile>(f); }

// One complete gzip member (header, deflate data, CRC-32 and length trailer) of `size` bytes at `level`; "" and
// `error` set when zlib fails.
std::string gzipMember(const unsigned char* data, std::size_t size, int level, std::string& error) {
  z_stream zs{};
  // windowBits 15 + 16: a gzip header and trailer; zlib's header carries no time stamp and no name.
  if (deflateInit2(&zs, level, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY) != Z_OK) {
    error = "cannot start zlib's deflate";
    return {};
  }
  std::string out(deflateBound(&zs, size), '\0');  // enough in one pass; grown below if not
  std::size_t offered = 0, produced = 0;
  int rc = Z_OK;
  while (rc == Z_OK) {
    if (zs.avail_in == 0 && offered < size) {  // zlib takes at most 4 GiB per call
      const std::size_t n = std::min<std::size_t>(size - offered, 1u << 30);
      zs.next_in = const_cast<Bytef*>(data + offered);
      zs.avail_in = static_cast<uInt>(n);
      offered += n;
    }
    if (produced == out.size()) out.resize(2 * out.size());
    const std::size_t room = std::min<std::size_t>(out.size() - produced, 1u << 30);
    zs.next_out = reinterpret_cast<Bytef*>(out.data() + produced);
    zs.avail_out = static_cast<uInt>(room);
    rc = deflate(&zs, offered == size && zs.avail_in == 0 ? Z_FINISH : Z_NO_FLUSH);
    produced += room - zs.avail_out;
  }
  const bool ok = rc == Z_STREAM_END;
  if (!ok && error.empty()) error = std::string("zlib's deflate failed (") + (zs.msg ? zs.msg : "no message") + ")";
  out.resize(ok ? produced : 0);
  deflateEnd(&zs);
  return out;
}
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

std::uint64_t verifyGzipFile(const fs::path& path) {
  {
    GzipInputStream probe(path);  // a missing file, or an uncompressed one (read as it is)
    if (!probe.compressed()) return probe.getTotalBytesCount();
  }
  // One pass of inflate over the members: it finds what gzread finds (corrupt deflate data, a CRC-32 or length
  // mismatch, a file that ends inside a member) and also where the last member ends. gzread ignores bytes after
  // it that do not start another member; they are no part of the data (a file appended to, or the end of
  // another file), so they are an error too.
  std::ifstream file(path, std::ios::binary);
  if (!file) throw Error(path.string() + ": cannot open (" + std::strerror(errno) + ")");
  std::error_code ec;
  const std::uint64_t size = fs::file_size(path, ec);
  z_stream zs{};
  if (inflateInit2(&zs, 15 + 16) != Z_OK) throw Error(path.string() + ": cannot start zlib's inflate");
  std::vector<unsigned char> in(128 * 1024), out(256 * 1024);
  std::uint64_t consumed = 0, total = 0;
  bool memberEnded = false, inputEnded = false;
  std::string failure;
  for (;;) {
    if (zs.avail_in == 0 && !inputEnded) {
      file.read(reinterpret_cast<char*>(in.data()), static_cast<std::streamsize>(in.size()));
      const auto got = static_cast<uInt>(file.gcount());
      inputEnded = got == 0;
      zs.next_in = in.data();
      zs.avail_in = got;
    }
    if (inputEnded && memberEnded) break;
    if (memberEnded) {
      // Another member must start here (gzip magic 1f 8b), or nothing at all.
      if (zs.next_in[0] != 0x1f || (zs.avail_in > 1 && zs.next_in[1] != 0x8b)) {
        failure = std::to_string(size - consumed) + " bytes after the end of the gzip data (at byte " +
                  std::to_string(consumed) + ": the file was appended to, or holds another file's end)";
        break;
      }
      inflateReset(&zs);
      memberEnded = false;
    }
    const uInt before = zs.avail_in;
    zs.next_out = out.data();
    zs.avail_out = static_cast<uInt>(out.size());
    const int rc = inflate(&zs, Z_NO_FLUSH);
    consumed += before - zs.avail_in;
    total += out.size() - zs.avail_out;
    if (rc == Z_STREAM_END) {
      memberEnded = true;
    } else if (rc == Z_BUF_ERROR && inputEnded) {  // no progress without more input: the file ends inside
      failure = "truncated: the gzip data ends at byte " + std::to_string(size) + " before the end of its stream";
      break;
    } else if (rc != Z_OK && rc != Z_BUF_ERROR) {
      failure = "corrupt gzip data (zlib: " + std::string(zs.msg ? zs.msg : "error " + std::to_string(rc)) +
                ", found at compressed byte " + std::to_string(consumed) + ")";
      break;
    }
  }
  inflateEnd(&zs);
  if (file.bad()) failure = std::string("read error (") + std::strerror(errno) + ")";
  if (!failure.empty()) throw Error(path.string() + ": " + failure);
  return total;
}

struct GzipOutputStream::Impl {
  struct Member {
    std::string bytes, error;
  };
  std::ofstream file;
  std::deque<std::future<Member>> pending;  // blocks being compressed, in file order
};

GzipOutputStream::GzipOutputStream(fs::path path, int level, std::size_t blockBytes, unsigned threads)
    : path_(std::move(path)), level_(level), blockBytes_(blockBytes), threads_(threads),
      impl_(std::make_unique<Impl>()) {
  if (level < 0 || level > 9) throw Error(path_.string() + ": gzip level " + std::to_string(level) + " is not in 0-9");
  if (blockBytes == 0) throw Error(path_.string() + ": gzip blocks of 0 bytes");
  if (threads == 0) throw Error(path_.string() + ": gzip compression on 0 threads");
  impl_->file.open(path_, std::ios::binary | std::ios::trunc);
  if (!impl_->file) throw Error(path_.string() + ": cannot open for writing (" + std::strerror(errno) + ")");
  block_.reserve(blockBytes_);
}

// The futures of std::async wait for their threads when the deque is destroyed.
GzipOutputStream::~GzipOutputStream() = default;

size_t GzipOutputStream::Write(const void* buffer, size_t count) {
  if (closed_) throw Error(path_.string() + ": written after it was closed");
  const char* bytes = static_cast<const char*>(buffer);
  for (size_t left = count; left > 0;) {
    const size_t n = std::min(left, blockBytes_ - block_.size());
    block_.append(bytes, n);
    bytes += n;
    left -= n;
    if (block_.size() == blockBytes_) submitBlock();
  }
  position_ += count;
  return count;
}

void GzipOutputStream::submitBlock() {
  if (impl_->pending.size() >= threads_) writeOldestMember();
  impl_->pending.push_back(std::async(std::launch::async, [level = level_, data = std::move(block_)] {
    Impl::Member m;
    m.bytes = gzipMember(reinterpret_cast<const unsigned char*>(data.data()), data.size(), level, m.error);
    return m;
  }));
  block_ = std::string();
  block_.reserve(blockBytes_);
  anyMember_ = true;
}

void GzipOutputStream::writeOldestMember() {
  const Impl::Member m = impl_->pending.front().get();
  impl_->pending.pop_front();
  if (!m.error.empty()) throw Error(path_.string() + ": " + m.error);
  impl_->file.write(m.bytes.data(), static_cast<std::streamsize>(m.bytes.size()));
  if (!impl_->file) throw Error(path_.string() + ": writing failed (" + std::strerror(errno) + ")");
}

void GzipOutputStream::close() {
  if (closed_) return;
  closed_ = true;
  if (!block_.empty() || !anyMember_) submitBlock();
  while (!impl_->pending.empty()) writeOldestMember();
  impl_->file.close();
  if (!impl_->file) throw Error(path_.string() + ": writing failed (" + std::strerror(errno) + ")");
}

size_t GzipOutputStream::Read(void*, size_t) { throw Error(path_.string() + ": opened for writing only"); }

uint64_t GzipOutputStream::Seek(int64_t, TSeekOrigin) { throw Error(path_.string() + ": the stream is not seekable"); }

uint64_t GzipOutputStream::getTotalBytesCount() const { return position_; }

uint64_t GzipOutputStream::getPosition() const { return position_; }

std::string GzipOutputStream::getStreamDescription() const { return "GzipOutputStream: " + path_.string(); }

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
  // MRPT could not even read an object header: the data is something else (text, another format), not a damaged
  // archive of ours (whose header it would read).
  if (what.find("parsing typed object ''") != std::string::npos ||
      what.find("old streaming header") != std::string::npos ||
      what.find("Class name has more than") != std::string::npos)
    throw Error(path.string() + ": not a " + fileKind + " (its data is not an MRPT archive)");
  if (const auto* err = dynamic_cast<const Error*>(&e)) throw *err;
  throw Error(path.string() + ": not a readable " + fileKind + " (truncated or corrupt: " + oneLineMessage(e) + ")");
}

}  // namespace pslam
