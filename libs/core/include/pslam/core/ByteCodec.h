#pragma once
// Little-endian fixed-size fields for the blobs a map file carries beside the map proper (its extensions: the line
// store, the direct points). The reader checks every read against the end of the blob and throws pslam::Error
// "<context>: ..." naming the field, so a damaged blob is refused with one line and nothing half-read is kept.
#include <cmath>
#include <cstdint>
#include <cstring>
#include <string>

#include "pslam/core/Error.h"

namespace pslam {

class ByteWriter {
 public:
  template <class T>
  void put(T v) {
    char b[sizeof(T)];
    std::memcpy(b, &v, sizeof(T));
    bytes_.append(b, sizeof(T));
  }
  void putBytes(const unsigned char* p, std::size_t n) { bytes_.append(reinterpret_cast<const char*>(p), n); }
  void putFlag(bool v) { put<std::uint8_t>(v ? 1 : 0); }
  /// Four magic characters and a u8 version: the header of a blob (ByteReader::header reads it).
  void putHeader(const char (&magic)[4], std::uint8_t version) {
    for (char c : magic) put(c);
    put(version);
  }
  std::string take() { return std::move(bytes_); }

 private:
  std::string bytes_;
};

class ByteReader {
 public:
  /// `context` starts every error message ("lines", "direct points"); `bytes` must outlive the reader.
  ByteReader(const std::string& bytes, std::string context) : b_(bytes), context_(std::move(context)) {}

  template <class T>
  T get(const char* what) {
    need(sizeof(T), what);
    T v;
    std::memcpy(&v, b_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  /// A double that must be finite.
  double finite(const char* what) {
    const double v = get<double>(what);
    if (!std::isfinite(v)) fail(std::string(what) + " is NaN or Inf");
    return v;
  }
  /// A u64 count of at most `max` items (guards against absurd counts in a corrupt blob).
  std::uint64_t count(const char* what, std::uint64_t max) {
    const auto n = get<std::uint64_t>(what);
    if (n > max) fail("implausible " + std::string(what) + " count " + std::to_string(n));
    return n;
  }
  void bytes(unsigned char* out, std::size_t n, const char* what) {
    need(n, what);
    std::memcpy(out, b_.data() + pos_, n);
    pos_ += n;
  }
  /// A u8 that must be 0 or 1.
  bool flag(const char* what) {
    const auto v = get<std::uint8_t>(what);
    if (v > 1) fail("flag '" + std::string(what) + "' is " + std::to_string(v) + " (expected 0 or 1)");
    return v == 1;
  }
  /// The header ByteWriter::putHeader wrote: `expected` magic ("not a <what> (bad magic)" otherwise) and `version`
  /// ("unsupported <what> version N (this build reads M)" otherwise).
  void header(const char (&expected)[4], std::uint8_t version, const char* what) {
    for (char c : expected)
      if (get<char>("magic") != c) fail(std::string("not a ") + what + " (bad magic)");
    const auto v = get<std::uint8_t>("version");
    if (v != version)
      fail(std::string("unsupported ") + what + " version " + std::to_string(v) + " (this build reads " +
           std::to_string(version) + ")");
  }
  bool atEnd() const { return pos_ == b_.size(); }
  [[noreturn]] void fail(const std::string& message) const { throw Error(context_ + ": " + message); }

 private:
  void need(std::size_t n, const char* what) const {
    if (b_.size() - pos_ < n) fail("truncated (at " + std::string(what) + ")");
  }
  const std::string& b_;
  std::string context_;
  std::size_t pos_ = 0;
};

}  // namespace pslam
