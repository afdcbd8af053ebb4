#pragma once
// Checks the serialized bytes of the next object of a rawlog before MRPT deserializes it. MRPT's readers take the
// sizes and counts they find at face value: CObservation3DRangeScan::serializeFrom calls rangeImage_setSize(rows,
// cols) with whatever the archive says, and a corrupt size (inside a valid gzip stream) makes it realloc and
// memset gigabytes, or a negative size: a segmentation fault, not an exception. So the reader looks ahead at the
// object's bytes (buffered, then handed to MRPT unchanged) and refuses sizes that do not fit in the bytes left.
#include <cstdint>
#include <string>

#include <mrpt/io/CStream.h>

namespace pslam::datasets::detail {

/// A read-only stream over `source` that can look ahead: peek() buffers bytes that later reads return first.
/// `totalBytes` is the length of the (decompressed) data, known from its verification, so that declared sizes
/// can be compared with the bytes left.
class PeekStream : public mrpt::io::CStream {
 public:
  PeekStream(mrpt::io::CStream& source, std::uint64_t totalBytes) : source_(source), total_(totalBytes) {}

  /// Makes at least `n` bytes available after the read position (fewer at the end of the data); returns how many.
  std::size_t peek(std::size_t n);
  /// The buffered byte `i` after the read position (i < peek(...)).
  unsigned char at(std::size_t i) const { return static_cast<unsigned char>(buffer_[offset_ + i]); }
  /// Bytes of the data after the read position.
  std::uint64_t bytesLeft() const { return total_ - position_; }

  size_t Read(void* buffer, size_t count) override;
  size_t Write(const void* buffer, size_t count) override;
  uint64_t Seek(int64_t offset, TSeekOrigin origin = sFromBeginning) override;
  uint64_t getTotalBytesCount() const override { return total_; }
  uint64_t getPosition() const override { return position_; }

 private:
  mrpt::io::CStream& source_;
  std::uint64_t total_;
  std::uint64_t position_ = 0;
  std::string buffer_;
  std::size_t offset_ = 0;  // read position inside buffer_
};

/// Returns "" when the next object in `in` may be handed to MRPT, else why not (e.g. "a DEPTH observation
/// declares a 4278190200x4278124286 range image (...)"). The observations of the rawlog contract are walked field by
/// field (CObservation3DRangeScan, CObservationImage with its CImage: sizes MRPT or OpenCV would allocate before
/// reading); other classes are left to MRPT, whose failures are exceptions.
std::string checkNextObject(PeekStream& in);

}  // namespace pslam::datasets::detail
