#include "ArchivePeek.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <limits>
#include <utility>

#include "pslam/core/Error.h"

namespace pslam::datasets::detail {

std::size_t PeekStream::peek(std::size_t n) {
  if (offset_ > 0 && offset_ >= buffer_.size() / 2) {  // drop what was read before growing
    buffer_.erase(0, offset_);
    offset_ = 0;
  }
  const std::uint64_t wanted = std::min<std::uint64_t>(n, bytesLeft());
  while (buffer_.size() - offset_ < wanted) {
    const std::size_t missing = static_cast<std::size_t>(wanted - (buffer_.size() - offset_));
    const std::size_t old = buffer_.size();
    buffer_.resize(old + missing);
    const std::size_t got = source_.Read(buffer_.data() + old, missing);
    buffer_.resize(old + got);
    if (got == 0) break;
  }
  return buffer_.size() - offset_;
}

size_t PeekStream::Read(void* buffer, size_t count) {
  auto* out = static_cast<char*>(buffer);
  std::size_t done = std::min(count, buffer_.size() - offset_);
  std::memcpy(out, buffer_.data() + offset_, done);
  offset_ += done;
  if (offset_ == buffer_.size()) {
    buffer_.clear();
    offset_ = 0;
  }
  if (done < count) done += source_.Read(out + done, count - done);
  position_ += done;
  return done;
}

size_t PeekStream::Write(const void*, size_t) { throw Error("PeekStream: read only"); }
uint64_t PeekStream::Seek(int64_t, TSeekOrigin) { throw Error("PeekStream: not seekable"); }

namespace {

/// A name read from the data, fit for a one-line message: other bytes than letters, digits, '_' and ':' as \xNN.
std::string printable(const std::string& name) {
  std::string out;
  for (unsigned char c : name) {
    if (std::isalnum(c) || c == '_' || c == ':') {
      out += static_cast<char>(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02X", c);
      out += buf;
    }
  }
  return out;
}

constexpr unsigned char kEndOfObject = 0x88;       // MRPT's end-of-object flag
constexpr std::uint64_t kMaxImagePixels = 1u << 26;  // 8192 x 8192: no camera of a rawlog comes near

/// A look-ahead cursor over the next object's bytes; every read is checked against the data left.
class Walker {
 public:
  explicit Walker(PeekStream& in) : in_(in) {}

  /// Thrown (as a message) when the object cannot be what it says; caught by checkNextObject.
  struct Refused {
    std::string why;
  };

  void need(std::uint64_t n) {
    if (n > in_.bytesLeft() - pos_)
      throw Refused{"it declares " + std::to_string(n) + " more bytes at byte " + std::to_string(pos_) +
                    " of the object, but the rawlog holds only " + std::to_string(in_.bytesLeft() - pos_)};
    if (in_.peek(static_cast<std::size_t>(pos_ + n)) < pos_ + n)
      throw Refused{"the rawlog ends inside the object"};
  }
  unsigned char u8() {
    need(1);
    return in_.at(static_cast<std::size_t>(pos_++));
  }
  std::uint32_t u32() {
    need(4);
    std::uint32_t v = 0;
    for (int k = 0; k < 4; ++k) v |= std::uint32_t(in_.at(static_cast<std::size_t>(pos_ + k))) << (8 * k);
    pos_ += 4;
    return v;
  }
  void skip(std::uint64_t n) {
    need(n);
    pos_ += n;
  }
  bool flag(const char* what) {
    const unsigned char b = u8();
    if (b > 1) throw Refused{std::string("flag '") + what + "' is " + std::to_string(b) + " (expected 0 or 1)"};
    return b == 1;
  }
  void string(const char* what) {
    const std::uint32_t n = u32();
    if (n > in_.bytesLeft() - pos_)
      throw Refused{std::string("its ") + what + " declares " + std::to_string(n) + " characters, more than the " +
                    std::to_string(in_.bytesLeft() - pos_) + " bytes left in the rawlog"};
    skip(n);
  }
  /// An object header (class name and version); returns the class name without its namespace. `oldFormat`: the
  /// header of MRPT < 0.5.5 (a 32-bit name length and version, no end flag).
  std::string header(int& version, bool* oldFormat = nullptr) {
    const unsigned char len = u8();
    const bool old = !(len & 0x80);
    if (oldFormat) *oldFormat = old;
    if (old && !oldFormat) throw Refused{"a nested object header of the old (MRPT < 0.5.5) format"};
    if (old) skip(3);
    const std::size_t n = len & 0x7f;
    need(n);
    std::string name;
    for (std::size_t i = 0; i < n; ++i) name += static_cast<char>(in_.at(static_cast<std::size_t>(pos_ + i)));
    pos_ += n;
    version = u8();
    const auto colon = name.rfind("::");
    return colon == std::string::npos ? name : name.substr(colon + 2);
  }
  void end(const std::string& what) {
    if (u8() != kEndOfObject) throw Refused{what + " does not end where its fields do"};
  }
  /// A nested object of class `cls` in one of `versions` (the layouts known to this walker).
  int nested(const char* cls, std::initializer_list<int> versions) {
    int version = -1;
    const std::string name = header(version);
    if (name != cls) throw Refused{"a class '" + printable(name) + "' where a " + cls + " belongs"};
    if (std::find(versions.begin(), versions.end(), version) == versions.end())
      throw Refused{std::string("a ") + cls + " of serialization version " + std::to_string(version) +
                    " (this reader knows the layout of the version this MRPT writes)"};
    return version;
  }
  void pose3D() {
    nested("CPose3D", {3});
    skip(12 * 8);  // translation and rotation matrix
    end("a CPose3D");
  }
  void camera() {
    const int v = nested("TCamera", {5, 6});
    skip(8 + 8 * 8 + 4 * 8);  // focal length in metres, 8 distortion terms, fx fy cx cy
    skip(4 + 4);              // nrows, ncols
    string("camera name");
    if (v >= 6) u8();  // distortion model
    end("a TCamera");
  }
  std::int32_t i32() { return static_cast<std::int32_t>(u32()); }
  /// Refuses `pixels` x `bytesPerPixel` when it cannot be in the bytes left (or exceeds kMaxImagePixels).
  void imageBytes(const std::string& declared, std::uint64_t pixels, std::uint64_t bytesPerPixel) {
    if (pixels > kMaxImagePixels)
      throw Refused{declared + " (more than the " + std::to_string(kMaxImagePixels) + " pixels this reader reads)"};
    if (pixels * bytesPerPixel > in_.bytesLeft() - pos_)
      throw Refused{declared + " (" + std::to_string(pixels * bytesPerPixel) + " bytes, more than the " +
                    std::to_string(in_.bytesLeft() - pos_) + " left in the rawlog)"};
  }
  /// A CImage (version 9, MRPT 2.x), field by field as its serializeFrom reads them: a file name, or the pixels
  /// (grey: raw bytes; colour: JPEG bytes or raw BGR), whose declared size MRPT allocates before it reads them.
  void image(const std::string& what) {
    nested("CImage", {9});
    if (flag("externally stored")) {
      string("image file name");
    } else if (u8() == 0) {  // grey: width, height, origin, size in bytes, pixel depth; a ZIP flag; the bytes
      const std::int32_t w = i32(), h = i32();
      i32();  // origin
      const std::uint32_t bytes = u32();
      const std::int32_t depth = i32();
      static const int kBytesPerDepth[] = {1, 1, 2, 2, 4, 4, 8};  // MRPT's PixelDepth: 8U 8S 16U 16S 32S 32F 64F
      const std::string declared = "a " + what + " declares a " + std::to_string(w) + "x" + std::to_string(h) +
                                   " grey image of pixel depth " + std::to_string(depth);
      if (w < 0 || h < 0 || depth < 0 || depth > 6) throw Refused{declared};
      imageBytes(declared, std::uint64_t(w) * std::uint64_t(h), kBytesPerDepth[depth]);
      if (flag("image stored as ZIP")) throw Refused{"a " + what + " stored ZIP-compressed (MRPT cannot read it)"};
      skip(bytes);
    } else {  // colour: width, height; JPEG bytes (both > 0), raw BGR (both < 0) or an empty image
      const std::int32_t w = i32(), h = i32();
      const std::string declared =
          "a " + what + " declares a " + std::to_string(w) + "x" + std::to_string(h) + " colour image";
      if (w >= 1 && h >= 1) {
        const std::uint32_t n = u32();
        if (n > in_.bytesLeft() - pos_)
          throw Refused{declared + " of " + std::to_string(n) + " JPEG bytes, more than the " +
                        std::to_string(in_.bytesLeft() - pos_) + " left in the rawlog"};
        skip(n);
      } else if (w < 0 && h < 0 && w != std::numeric_limits<std::int32_t>::min() &&
                 h != std::numeric_limits<std::int32_t>::min()) {
        imageBytes(declared, std::uint64_t(-std::int64_t(w)) * std::uint64_t(-std::int64_t(h)), 3);
        skip(std::uint64_t(-std::int64_t(w)) * std::uint64_t(-std::int64_t(h)) * 3);
      } else if (w != 0 && h != 0) {
        throw Refused{declared};
      }
    }
    end("a CImage");
  }
  // CObservationImage, version 4 (MRPT 2.x): camera pose, camera, image, time stamp, sensor label.
  void observationImage(int version) {
    if (version != 4)
      throw Refused{"a CObservationImage of serialization version " + std::to_string(version) +
                    " (this reader reads version 4)"};
    pose3D();
    camera();
    image("CObservationImage");
    skip(8);  // timestamp
    string("sensor label");
    end("the CObservationImage");
  }
  /// The range image size fields: refused when the image cannot be in the bytes left.
  void rangeImage(const char* what) {
    const std::uint32_t rows = u32(), cols = u32();
    const std::uint64_t pixels = std::uint64_t(rows) * cols;
    const std::string declared = std::string("a DEPTH observation declares a ") + std::to_string(rows) + "x" +
                                 std::to_string(cols) + " " + what;
    if (pixels > kMaxImagePixels)
      throw Refused{declared + " (more than the " + std::to_string(kMaxImagePixels) + " pixels this reader reads)"};
    if (2 * pixels > in_.bytesLeft() - pos_)
      throw Refused{declared + " (" + std::to_string(2 * pixels) + " bytes, more than the " +
                    std::to_string(in_.bytesLeft() - pos_) + " left in the rawlog)"};
    skip(2 * pixels);
  }

  // CObservation3DRangeScan, versions 9 and 10 (MRPT 2.x), field by field as its serializeFrom reads them.
  void rangeScan(int version) {
    if (version != 9 && version != 10)
      throw Refused{"a CObservation3DRangeScan of serialization version " + std::to_string(version) +
                    " (this reader reads versions 9 and 10)"};
    skip(4);  // maxRange
    pose3D();
    if (flag("hasPoints3D")) {
      const std::uint32_t n = u32();
      // x, y, z (float) and the pixel of each point (uint16 x 2)
      if (std::uint64_t(n) * 16 > in_.bytesLeft() - pos_)
        throw Refused{"a DEPTH observation declares " + std::to_string(n) + " 3D points, more than the rawlog holds"};
      skip(std::uint64_t(n) * 16);
    }
    const bool hasRange = flag("hasRangeImage");
    skip(4);  // rangeUnits
    if (hasRange) rangeImage("range image");
    if (flag("hasIntensityImage")) image("DEPTH observation's intensity image");
    if (flag("hasConfidenceImage")) image("DEPTH observation's confidence image");
    camera();
    camera();
    pose3D();
    skip(4 + 8);  // stdError, timestamp
    string("sensor label");
    flag("points3D external");
    string("points3D file name");
    flag("rangeImage external");
    string("range image file name");
    flag("range_is_depth");
    u8();  // intensity channel
    if (flag("pixel labels")) throw Refused{"a DEPTH observation with pixel labels (not read by this reader)"};
    if (version >= 10) {
      const unsigned layers = u8();
      for (unsigned i = 0; i < layers; ++i) {
        string("layer name");
        rangeImage("range image layer");
      }
    }
    end("the CObservation3DRangeScan");
  }

 private:
  PeekStream& in_;
  std::uint64_t pos_ = 0;
};

}  // namespace

std::string checkNextObject(PeekStream& in) {
  if (in.peek(1) == 0) return "";  // the end: MRPT reports it as such
  Walker w(in);
  std::string cls;
  int version = -1;
  bool oldFormat = false;
  try {
    cls = w.header(version, &oldFormat);
  } catch (const Walker::Refused&) {
    return "";  // a header MRPT cannot read either: its own error says so
  }
  if (cls != "CObservation3DRangeScan" && cls != "CObservationImage") return "";
  try {
    if (oldFormat) throw Walker::Refused{"a " + cls + " in the old (MRPT < 0.5.5) format"};
    if (cls == "CObservationImage")
      w.observationImage(version);
    else
      w.rangeScan(version);
  } catch (const Walker::Refused& r) {
    return r.why;
  }
  return "";
}

}  // namespace pslam::datasets::detail
