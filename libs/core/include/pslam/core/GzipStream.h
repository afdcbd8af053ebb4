#pragma once
// Verified reading of gzip-compressed MRPT archives (rawlogs, maps), and block-parallel writing of them (maps).
// MRPT's CFileGZInputStream takes every zlib error for the end of the file, so a corrupt or cut file reads as a
// shorter valid one, and never checks the gzip trailer. This stream reads through zlib directly and reports every
// error instead: corrupt deflate data, a CRC-32 or length mismatch in the trailer, data that ends before the
// trailer. It streams (a 128 KiB buffer), so rawlogs of any size are read in constant memory.
#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include <mrpt/io/CStream.h>

#include "pslam/core/Error.h"

namespace pslam {

class GzipInputStream : public mrpt::io::CStream {
 public:
  /// Opens `path`: gzip, or an uncompressed file, which is read as it is (MRPT also reads plain archives;
  /// compressed() tells). Throws pslam::Error naming the file if it is missing or cannot be opened.
  explicit GzipInputStream(std::filesystem::path path);
  ~GzipInputStream() override;
  GzipInputStream(const GzipInputStream&) = delete;
  GzipInputStream& operator=(const GzipInputStream&) = delete;

  /// Reads up to `count` bytes; fewer only at the verified end of the data (for gzip: the CRC-32 and the length
  /// in the trailer match what was read). On any zlib or I/O error, throws pslam::Error
  /// "<file>: <reason>" and keeps the reason in failure(); later reads throw it again.
  size_t Read(void* buffer, size_t count) override;
  size_t Write(const void* buffer, size_t count) override;  ///< throws: the stream is read-only
  uint64_t Seek(int64_t offset, TSeekOrigin origin = sFromBeginning) override;  ///< throws: not seekable
  uint64_t getTotalBytesCount() const override;  ///< size of the file on disk
  uint64_t getPosition() const override;         ///< (uncompressed) bytes delivered so far
  std::string getStreamDescription() const override;

  const std::filesystem::path& path() const { return path_; }
  bool compressed() const { return compressed_; }
  /// True once a read stopped at the verified end of the data.
  bool atEnd() const { return atEnd_; }
  /// Why a read failed, without the file name ("" if none), e.g. "corrupt gzip data (zlib: incorrect data
  /// check, found at compressed byte 812)". MRPT's archive turns exceptions thrown while an object is read into
  /// its own end-of-file exception, so callers look here first.
  const std::string& failure() const { return failure_; }
  /// Requires the verified end of the data now (e.g. after the one object of a map file): throws pslam::Error
  /// if more data follows, or if the end is corrupt.
  void requireEnd();

 private:
  [[noreturn]] void fail();
  std::filesystem::path path_;
  void* file_ = nullptr;  // gzFile
  bool compressed_ = true;
  bool atEnd_ = false;
  std::uint64_t position_ = 0;
  std::uint64_t fileSize_ = 0;
  std::string failure_;
};

/// Reads `path` once to its end and verifies it (no-op for an uncompressed file): throws pslam::Error
/// "<file>: <reason>" (as GzipInputStream::Read) on any error, and on bytes after the last gzip member (which
/// zlib would ignore). Readers call it before they interpret any data, so that data a corrupt gzip stream would
/// deliver before its CRC-32 is checked at the end (garbage sizes and counts) never reaches a deserializer.
/// Returns the length of the data (decompressed; the file's size for an uncompressed file), against which
/// readers check the sizes an archive declares. Streams with fixed buffers; costs one decompression of the file.
std::uint64_t verifyGzipFile(const std::filesystem::path& path);

/// Gzip-compressed writing of MRPT archives (maps) that uses more than one core: the bytes written are cut into
/// blocks of `blockBytes`, and each block becomes one gzip member (RFC 1952 allows several; zlib's readers,
/// GzipInputStream, gzip and Python read them as one stream), compressed on a thread of its own while the writer
/// goes on; the members are written in order. At most `threads` blocks are compressed at once, so memory stays
/// about (threads + 1) blocks whatever the size of the data. The file's bytes depend on the data, the level, the
/// block size and zlib's version only (no time stamp, no file name, not the thread count or timing).
/// Why: saving the map is the serial end of every run, and deflate is most of its time. Writes `path` directly
/// (callers write to a temporary file and rename: AtomicOutput). Errors throw pslam::Error "<path>: <reason>".
class GzipOutputStream : public mrpt::io::CStream {
 public:
  static constexpr std::size_t kDefaultBlockBytes = std::size_t(1) << 20;
  /// Opens (truncates) `path`. Throws on a level outside 0-9, a zero block size or thread count, or when the file
  /// cannot be opened.
  GzipOutputStream(std::filesystem::path path, int level, std::size_t blockBytes = kDefaultBlockBytes,
                   unsigned threads = 2);
  /// Without close(): waits for the blocks being compressed and closes the file, which is then incomplete.
  ~GzipOutputStream() override;
  GzipOutputStream(const GzipOutputStream&) = delete;
  GzipOutputStream& operator=(const GzipOutputStream&) = delete;

  size_t Write(const void* buffer, size_t count) override;
  /// Compresses what is left, writes every member and closes the file; throws if compressing or writing failed.
  /// A stream to which nothing was written gives one empty member (a valid gzip file). Later writes throw.
  void close();
  size_t Read(void* buffer, size_t count) override;                             ///< throws: write-only
  uint64_t Seek(int64_t offset, TSeekOrigin origin = sFromBeginning) override;  ///< throws: not seekable
  uint64_t getTotalBytesCount() const override;  ///< (uncompressed) bytes written so far
  uint64_t getPosition() const override;         ///< the same
  std::string getStreamDescription() const override;

 private:
  struct Impl;
  void submitBlock();
  void writeOldestMember();
  std::filesystem::path path_;
  int level_;
  std::size_t blockBytes_;
  unsigned threads_;
  std::uint64_t position_ = 0;
  bool closed_ = false, anyMember_ = false;
  std::string block_;
  std::unique_ptr<Impl> impl_;
};

/// The one error line of a failed read of a single-object MRPT archive file (maps, vocabularies), from the
/// exception `e` that reading threw. The first failure wins: the gzip stream's, then `contentFailure` (what the
/// object's own reader found: MRPT replaces exceptions thrown inside an object with its own end-of-file one), then
/// another MRPT object in the file ("not a <fileKind> (it holds a <class>)"), then a pslam::Error as it is, else
/// "not a readable <fileKind> (truncated or corrupt: ...)". Always throws pslam::Error naming `path`.
[[noreturn]] void throwArchiveReadError(const std::filesystem::path& path, const std::exception& e,
                                        const GzipInputStream& stream, const std::string& contentFailure,
                                        const std::string& fileKind);

/// The body of a single-object archive's serializeFrom() (maps, vocabularies): runs `read`, keeping why it failed in
/// `failure` (a pslam::Error's message, or "malformed <what> data (...)" for MRPT's own exceptions, e.g. the archive
/// ending inside the object), then rethrows. MRPT replaces the message of exceptions thrown inside an object, so
/// the loader reports `failure` (throwArchiveReadError).
template <class Read>
void readRecordingFailure(std::string& failure, const std::string& what, Read&& read) {
  failure.clear();
  try {
    read();
  } catch (const Error& e) {
    failure = e.what();
    throw;
  } catch (const std::exception& e) {
    failure = "malformed " + what + " data (" + oneLineMessage(e) + ")";
    throw;
  }
}

}  // namespace pslam
