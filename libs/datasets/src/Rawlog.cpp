#include "pslam/datasets/Rawlog.h"

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <deque>
#include <optional>
#include <vector>

#include <mrpt/io/CFileGZOutputStream.h>
#include <mrpt/io/lazy_load_path.h>
#include <mrpt/obs/CObservation3DRangeScan.h>
#include <mrpt/obs/CObservationImage.h>
#include <mrpt/serialization/CArchive.h>
#include <mrpt/system/datetime.h>
#include <opencv2/imgcodecs.hpp>

#include "ArchivePeek.h"
#include "pslam/core/Error.h"
#include "pslam/core/GzipStream.h"

namespace fs = std::filesystem;

namespace pslam::datasets {

namespace {

constexpr double kSameFrameTolerance = 1e-6;  // seconds; channels of one frame share the CAMERA stamp

std::string frameContext(const fs::path& p, std::size_t index) {
  return p.string() + ": frame " + std::to_string(index);
}

}  // namespace

void validateFrame(const Frame& f, const std::string& ctx) {
  require(std::isfinite(f.timestamp), ctx, "timestamp is NaN or Inf");
  require(!f.image.empty(), ctx, "empty CAMERA image");
  require(f.image.depth() == CV_8U && (f.image.channels() == 1 || f.image.channels() == 3), ctx,
          "CAMERA image must be 8-bit grey or 8-bit BGR");
  const auto& c = f.camera;
  require(c.ncols == static_cast<uint32_t>(f.image.cols) && c.nrows == static_cast<uint32_t>(f.image.rows), ctx,
          "intrinsics are for " + std::to_string(c.ncols) + "x" + std::to_string(c.nrows) + " but the image is " +
              std::to_string(f.image.cols) + "x" + std::to_string(f.image.rows));
  require(std::isfinite(c.fx()) && std::isfinite(c.fy()) && c.fx() > 0 && c.fy() > 0, ctx,
          "focal lengths must be positive and finite");
  require(std::isfinite(c.cx()) && std::isfinite(c.cy()), ctx, "principal point is NaN or Inf");
  for (double d : c.dist) require(std::isfinite(d), ctx, "distortion coefficient is NaN or Inf");
  if (!f.depth.empty()) {
    require(f.depth.type() == CV_16UC1, ctx, "DEPTH must be 16-bit single channel");
    require(f.depth.size() == f.image.size(), ctx, "DEPTH size differs from the CAMERA image");
    require(std::isfinite(f.depthUnits) && f.depthUnits > 0, ctx, "depth units must be positive");
  }
  if (!f.semantic.empty()) {
    require(f.semantic.type() == CV_8UC3, ctx, "SEMANTIC must be 8-bit 3-channel");
    require(f.semantic.size() == f.image.size(), ctx, "SEMANTIC size differs from the CAMERA image");
  }
  if (!f.normals.empty()) {
    require(f.normals.type() == CV_8UC3, ctx, "NORMALS must be 8-bit 3-channel");
    require(f.normals.size() == f.image.size(), ctx, "NORMALS size differs from the CAMERA image");
  }
}

cv::Vec3b encodeNormal(const cv::Vec3d& n) {
  cv::Vec3b px;
  for (int k = 0; k < 3; ++k) {
    const double v = std::round((std::clamp(n[k], -1.0, 1.0) + 1.0) * 0.5 * 255.0);
    px[k] = static_cast<uchar>(v);
  }
  if (px == cv::Vec3b(0, 0, 0)) px[2] = 1;  // (-1,-1,-1)/sqrt3 never occurs as unit normal; keep 0 reserved
  return px;
}

bool decodeNormal(const cv::Vec3b& px, cv::Vec3d& n) {
  if (px[0] == 0 && px[1] == 0 && px[2] == 0) return false;
  for (int k = 0; k < 3; ++k) n[k] = px[k] / 255.0 * 2.0 - 1.0;
  const double norm = cv::norm(n);
  if (norm < 1e-6) return false;
  n /= norm;
  return true;
}

// ------------------------------------------------------------------------------------------------ writer
struct RawlogWriter::Impl {
  fs::path rawlogPath;
  std::string ext;
  std::optional<AtomicOutput> ownImages;  // without an OutputSet: the writer's own outputs
  std::optional<AtomicOutput> ownRawlog;
  AtomicOutput* rawlogOut = nullptr;
  AtomicOutput* imagesOut = nullptr;
  mrpt::io::CFileGZOutputStream stream;
  std::optional<cv::Size> size;
  bool open = false;
};

fs::path RawlogWriter::imagesDirFor(const fs::path& rawlogPath) {
  return rawlogPath.parent_path() / (rawlogPath.stem().string() + "_Images");
}

OutputKind RawlogWriter::imagesFolderKind() {
  return OutputKind::folder("(CAMERA|SEMANTIC|NORMALS)_[0-9]{6,}\\.(png|bmp|tiff|ppm|pgm)");
}

std::vector<fs::path> RawlogWriter::inputFilesOf(const fs::path& rawlogPath) {
  if (rawlogPath.empty()) return {};
  return {rawlogPath, imagesDirFor(rawlogPath)};
}

RawlogWriter::RawlogWriter(fs::path rawlogPath, std::string imageExtension, OutputSet* outputs)
    : impl_(std::make_unique<Impl>()) {
  auto& d = *impl_;
  d.rawlogPath = std::move(rawlogPath);
  d.ext = std::move(imageExtension);
  if (!d.ext.empty() && d.ext[0] == '.') d.ext.erase(0, 1);
  require(d.ext == "png" || d.ext == "bmp" || d.ext == "tiff" || d.ext == "ppm" || d.ext == "pgm",
          d.rawlogPath.string(), "image format '" + d.ext + "' is not lossless (use png, bmp, tiff, ppm or pgm)");
  // Images first: committed in this order, a reader never sees the rawlog without its images.
  if (outputs) {
    d.imagesOut = &outputs->add(imagesDirFor(d.rawlogPath), imagesFolderKind());
    d.rawlogOut = &outputs->add(d.rawlogPath);
  } else {
    d.imagesOut = &d.ownImages.emplace(imagesDirFor(d.rawlogPath), imagesFolderKind());
    d.rawlogOut = &d.ownRawlog.emplace(d.rawlogPath);
  }
  if (!d.stream.open(d.rawlogOut->tempPath().string(), 1))
    throw Error(d.rawlogPath.string() + ": cannot open for writing");
  d.open = true;
}

RawlogWriter::~RawlogWriter() {
  if (impl_ && impl_->open) impl_->stream.close();
}

void RawlogWriter::write(const Frame& f) {
  auto& d = *impl_;
  require(d.open, d.rawlogPath.string(), "write after commit");
  const std::string ctx = d.rawlogPath.string() + ": frame " + std::to_string(frames_);
  validateFrame(f, ctx);
  if (!d.size) d.size = f.image.size();
  require(*d.size == f.image.size(), ctx,
          "image size " + std::to_string(f.image.cols) + "x" + std::to_string(f.image.rows) +
              " differs from the first frame's " + std::to_string(d.size->width) + "x" +
              std::to_string(d.size->height));

  const auto stamp = mrpt::Clock::fromDouble(f.timestamp);
  auto arch = mrpt::serialization::archiveFrom(d.stream);
  char name[64];

  auto writeImage = [&](const cv::Mat& m, const char* label) {
    std::snprintf(name, sizeof(name), "%s_%06zu.%s", label, frames_, d.ext.c_str());
    const fs::path file = d.imagesOut->tempPath() / name;
    // PNG level 1: lossless like any level, several times faster to write than OpenCV's default 3 for a
    // few percent more disk (the writer is on the critical path of conversion and generation).
    static const std::vector<int> kPngParams{cv::IMWRITE_PNG_COMPRESSION, 1};
    errno = 0;
    bool written = false;
    std::string why;
    try {
      written = cv::imwrite(file.string(), m, d.ext == "png" ? kPngParams : std::vector<int>{});
    } catch (const cv::Exception& e) {
      why = oneLineMessage(e);
    }
    if (!written) {
      // OpenCV says only "false": the reason (a full disk, a file-size limit) is in errno.
      if (why.empty()) why = errno ? std::strerror(errno) : "the encoder failed";
      throw Error(ctx + ": cannot write image " + file.string() + " (" + why + ")");
    }
    auto obs = mrpt::obs::CObservationImage::Create();
    obs->sensorLabel = label;
    obs->timestamp = stamp;
    obs->cameraParams = f.camera;
    obs->cameraPose = f.sensorPoseOnBody;
    obs->image.setExternalStorage(name);
    arch << *obs;
  };

  writeImage(f.image, kCameraLabel);
  if (f.hasDepth()) {
    auto obs = mrpt::obs::CObservation3DRangeScan::Create();
    obs->sensorLabel = kDepthLabel;
    obs->timestamp = stamp;
    obs->hasRangeImage = true;
    obs->range_is_depth = true;
    obs->rangeUnits = static_cast<float>(f.depthUnits);
    obs->rangeImage_setSize(f.depth.rows, f.depth.cols);
    for (int r = 0; r < f.depth.rows; ++r) {
      const auto* row = f.depth.ptr<uint16_t>(r);
      for (int c = 0; c < f.depth.cols; ++c) obs->rangeImage(r, c) = row[c];
    }
    obs->cameraParams = f.camera;
    obs->cameraParamsIntensity = f.camera;
    obs->sensorPose = f.sensorPoseOnBody;
    obs->maxRange = static_cast<float>(65535 * f.depthUnits);
    arch << *obs;
  }
  if (f.hasSemantic()) writeImage(f.semantic, kSemanticLabel);
  if (f.hasNormals()) writeImage(f.normals, kNormalsLabel);
  ++frames_;
}

void RawlogWriter::commit() {
  auto& d = *impl_;
  require(d.open, d.rawlogPath.string(), "commit called twice");
  d.stream.close();
  d.open = false;
  if (d.ownImages) d.ownImages->commit();
  if (d.ownRawlog) d.ownRawlog->commit();
}

// ------------------------------------------------------------------------------------------------ reader
namespace {

/// The objects of a rawlog, read from a verified gzip stream. MRPT's archive reports any failure inside an
/// object as end of file; the end is taken as such only when no byte of a next object was read and the gzip
/// stream ended verified. Everything else is an error naming the file, the object and the frame.
class ObjectStream {
 public:
  ObjectStream(const fs::path& path, std::uint64_t totalBytes)
      : path_(path), stream_(path), peek_(stream_, totalBytes) {}

  /// The next object, or nullptr at the end. `framesBefore` (CAMERA observations read before it) is only for
  /// the message.
  mrpt::serialization::CSerializable::Ptr next(std::size_t framesBefore) {
    if (end_) return nullptr;
    const std::uint64_t before = peek_.getPosition();
    std::string refused;
    try {
      // Sizes MRPT would trust are checked first (ArchivePeek.h): a corrupt one must not reach its allocation.
      refused = detail::checkNextObject(peek_);
    } catch (const std::exception&) {
      // A read error of the gzip stream while looking ahead: reported below from stream_.failure().
    }
    if (!refused.empty())
      throw Error(path_.string() + ": corrupt rawlog at object " + std::to_string(objects_) + " (after " +
                  std::to_string(framesBefore) + " frames): " + refused);
    try {
      auto arch = mrpt::serialization::archiveFrom(peek_);
      auto obj = arch.ReadObject();
      if (!obj) throw Error("a null object");  // MRPT's "nullptr" record: never written to a rawlog
      ++objects_;
      return obj;
    } catch (const std::exception& e) {
      if (stream_.failure().empty() && stream_.atEnd() && peek_.getPosition() == before) {
        end_ = true;
        return nullptr;
      }
      const std::string mrpt = oneLineMessage(e);
      std::string why = !stream_.failure().empty() ? stream_.failure()
                        : peek_.getPosition() == before ? mrpt
                                                          : "object cut short or malformed (" + mrpt + ")";
      if (const auto at = mrpt.find("has class '"); stream_.failure().empty() && at != std::string::npos)
        why = "an object of the unknown class '" + mrpt.substr(at + 11, mrpt.find('\'', at + 11) - at - 11) +
              "' (not a rawlog of observations?)";
      throw Error(path_.string() + ": corrupt rawlog at object " + std::to_string(objects_) + " (after " +
                  std::to_string(framesBefore) + " frames): " + why);
    }
  }
  std::size_t objectsRead() const { return objects_; }

 private:
  fs::path path_;
  GzipInputStream stream_;
  detail::PeekStream peek_;
  std::size_t objects_ = 0;
  bool end_ = false;
};

std::unique_ptr<ObjectStream> openRawlog(const fs::path& path) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw Error(path.string() + ": rawlog file not found");
  // The whole gzip stream is verified before any object is decoded: data that a corrupt stream delivers before
  // its CRC-32 is checked (garbage sizes and counts) never reaches MRPT's deserialization.
  std::uint64_t bytes = 0;
  try {
    bytes = verifyGzipFile(path);
  } catch (const Error& e) {
    const std::string prefix = path.string() + ": ";
    const std::string what = e.what();
    throw Error(prefix + "corrupt rawlog: " + (what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : what));
  }
  return std::make_unique<ObjectStream>(path, bytes);
}

}  // namespace

/// The observations of one frame: its CAMERA and the channels that share its stamp.
struct FrameObjects {
  mrpt::obs::CObservationImage::Ptr camera;
  std::vector<mrpt::obs::CObservation::Ptr> channels;
  double stamp() const { return mrpt::Clock::toDouble(camera->timestamp); }
};

struct RawlogReader::Impl {
  fs::path path;
  fs::path imagesDir;
  std::unique_ptr<ObjectStream> objects;
  mrpt::serialization::CSerializable::Ptr pending;  // the next object, already read (look-ahead)
  std::size_t frameIndex = 0;
  std::optional<cv::Size> size;
  RawlogChannels channels;
  StampOrder order = StampOrder::strict;
  std::optional<double> lastStamp;
  std::deque<FrameObjects> sorted;  // StampOrder::sort: every frame, read at the start
  std::vector<std::string> warnings;

  /// `framesBefore`: CAMERA observations read so far (for messages).
  mrpt::serialization::CSerializable::Ptr readObject(std::size_t framesBefore) {
    if (pending) return std::exchange(pending, nullptr);
    return objects->next(framesBefore);
  }
  std::size_t objectIndex() const { return objects->objectsRead(); }
  bool readFrameObjects(FrameObjects& fo, std::size_t frame);
};

RawlogReader::RawlogReader(fs::path rawlogPath, RawlogChannels channels, StampOrder order)
    : impl_(std::make_unique<Impl>()) {
  auto& d = *impl_;
  d.path = std::move(rawlogPath);
  d.channels = channels;
  d.order = order;
  d.objects = openRawlog(d.path);
  d.imagesDir = RawlogWriter::imagesDirFor(d.path);
  if (order == StampOrder::sort) {
    // The frames' observations (images stay in their files until next()) are read first and sorted by stamp.
    FrameObjects fo;
    std::size_t back = 0, same = 0;
    std::optional<double> last;
    try {
      while (d.readFrameObjects(fo, d.sorted.size())) {
        if (last && fo.stamp() < *last) ++back;
        if (last && fo.stamp() == *last) ++same;
        last = fo.stamp();
        d.sorted.push_back(std::move(fo));
      }
    } catch (const Error&) {
      throw;
    } catch (const std::exception& e) {
      throw Error(frameContext(d.path, d.sorted.size()) + ": " + oneLineMessage(e));
    }
    if (back > 0)
      d.warnings.push_back(d.path.string() + ": " + std::to_string(back) +
                           " frame(s) stamped before the frame before them; the frames are read in stamp order");
    if (same > 0)
      d.warnings.push_back(d.path.string() + ": " + std::to_string(same) +
                           " frame(s) with the stamp of the frame before them; kept in the rawlog's order");
    std::stable_sort(d.sorted.begin(), d.sorted.end(),
                     [](const FrameObjects& a, const FrameObjects& b) { return a.stamp() < b.stamp(); });
  }
}

RawlogReader::~RawlogReader() = default;

const fs::path& RawlogReader::path() const { return impl_->path; }
const std::vector<std::string>& RawlogReader::warnings() const { return impl_->warnings; }
const fs::path& RawlogReader::imagesDir() const { return impl_->imagesDir; }

namespace {

cv::Mat loadImage(const mrpt::img::CImage& img, const fs::path& imagesDir, const std::string& ctx) {
  if (img.isExternallyStored()) {
    const fs::path file = imagesDir / img.getExternalStorageFile();
    cv::Mat m = cv::imread(file.string(), cv::IMREAD_UNCHANGED);
    if (m.empty()) throw Error(ctx + ": cannot read image file " + file.string());
    return m;
  }
  return img.asCvMat<cv::Mat>(mrpt::img::DEEP_COPY);
}

}  // namespace

bool RawlogReader::next(Frame& f) {
  auto& d = *impl_;
  try {
    return readFrame(f);
  } catch (const Error&) {
    throw;
  } catch (const std::exception& e) {  // MRPT / OpenCV failures while decoding the frame's data
    throw Error(frameContext(d.path, d.frameIndex) + ": " + oneLineMessage(e));
  }
}

bool RawlogReader::Impl::readFrameObjects(FrameObjects& fo, std::size_t frame) {
  fo = FrameObjects{};
  // Skip objects that are not observations of the contract until a CAMERA appears.
  while (!fo.camera) {
    auto obj = readObject(frame);
    if (!obj) return false;
    auto obs = std::dynamic_pointer_cast<mrpt::obs::CObservation>(obj);
    if (!obs) {
      throw Error(path.string() + ": object " + std::to_string(objectIndex() - 1) + " is a " +
                  obj->GetRuntimeClass()->className +
                  ", not an observation (only observation-only rawlogs are supported)");
    }
    if (obs->sensorLabel == kCameraLabel) {
      fo.camera = std::dynamic_pointer_cast<mrpt::obs::CObservationImage>(obs);
      if (!fo.camera) throw Error(frameContext(path, frame) + ": CAMERA observation is not a CObservationImage");
    } else if (obs->sensorLabel == kDepthLabel || obs->sensorLabel == kSemanticLabel ||
               obs->sensorLabel == kNormalsLabel) {
      throw Error(frameContext(path, frame) + ": " + obs->sensorLabel +
                  " observation without a preceding CAMERA observation of the same timestamp");
    }
  }
  const double stamp = fo.stamp();
  // The channels that share the CAMERA timestamp.
  for (;;) {
    auto obj = readObject(frame + 1);
    if (!obj) break;
    auto obs = std::dynamic_pointer_cast<mrpt::obs::CObservation>(obj);
    if (!obs || obs->sensorLabel == kCameraLabel ||
        std::abs(mrpt::Clock::toDouble(obs->timestamp) - stamp) > kSameFrameTolerance) {
      pending = obj;
      break;
    }
    fo.channels.push_back(obs);
  }
  return true;
}

bool RawlogReader::readFrame(Frame& f) {
  auto& d = *impl_;
  FrameObjects fo;
  if (d.order == StampOrder::sort) {
    if (d.sorted.empty()) return false;
    fo = std::move(d.sorted.front());
    d.sorted.pop_front();
  } else {
    if (!d.readFrameObjects(fo, d.frameIndex)) return false;
  }
  const auto& cam = fo.camera;
  const std::string ctx = frameContext(d.path, d.frameIndex);
  f = Frame{};
  f.index = d.frameIndex;
  f.timestamp = mrpt::Clock::toDouble(cam->timestamp);
  // Frames must follow each other in time: a stamp going back or repeated would be sorted (or paired) silently
  // by everything downstream (trajectories, evaluation). StampOrder::sort reads them in stamp order instead.
  if (d.order == StampOrder::strict && d.lastStamp && std::isfinite(f.timestamp)) {
    char buf[160];
    if (f.timestamp < *d.lastStamp) {
      std::snprintf(buf, sizeof buf, "timestamp %.6f is before the previous frame's %.6f", f.timestamp, *d.lastStamp);
      throw Error(ctx + ": " + buf + " (frames must be in time order; slam-run --sort-stamps reads them sorted)");
    }
    if (f.timestamp == *d.lastStamp) {
      std::snprintf(buf, sizeof buf, "timestamp %.6f is the previous frame's", f.timestamp);
      throw Error(ctx + ": " + buf + " (two frames at one time; slam-run --sort-stamps reads them anyway)");
    }
  }
  d.lastStamp = f.timestamp;
  f.camera = cam->cameraParams;
  f.sensorPoseOnBody = cam->cameraPose;
  f.image = loadImage(cam->image, d.imagesDir, ctx + " CAMERA");

  for (const auto& obs : fo.channels) {
    if (obs->sensorLabel == kDepthLabel) {
      auto depth = std::dynamic_pointer_cast<mrpt::obs::CObservation3DRangeScan>(obs);
      if (!depth || !depth->hasRangeImage) throw Error(ctx + ": DEPTH observation has no range image");
      if (!depth->range_is_depth) throw Error(ctx + ": DEPTH must hold depth (range_is_depth=true)");
      if (!d.channels.depth) continue;
      depth->load();
      const auto& R = depth->rangeImage;
      f.depth.create(static_cast<int>(R.rows()), static_cast<int>(R.cols()), CV_16UC1);
      for (int r = 0; r < f.depth.rows; ++r) {
        auto* row = f.depth.ptr<uint16_t>(r);
        for (int c = 0; c < f.depth.cols; ++c) row[c] = R(r, c);
      }
      f.depthUnits = depth->rangeUnits;
    } else if (obs->sensorLabel == kSemanticLabel || obs->sensorLabel == kNormalsLabel) {
      auto img = std::dynamic_pointer_cast<mrpt::obs::CObservationImage>(obs);
      if (!img) throw Error(ctx + ": " + obs->sensorLabel + " observation is not a CObservationImage");
      const bool semantic = obs->sensorLabel == kSemanticLabel;
      if (!(semantic ? d.channels.semantic : d.channels.normals)) continue;
      cv::Mat m = loadImage(img->image, d.imagesDir, ctx + " " + obs->sensorLabel);
      (semantic ? f.semantic : f.normals) = m;
    }
    // Other labels (IMU, GPS, ...) are ignored by this contract.
  }

  validateFrame(f, ctx);
  if (!d.size) d.size = f.image.size();
  require(*d.size == f.image.size(), ctx,
          "image size " + std::to_string(f.image.cols) + "x" + std::to_string(f.image.rows) +
              " differs from the first frame's " + std::to_string(d.size->width) + "x" +
              std::to_string(d.size->height));
  ++d.frameIndex;
  return true;
}

std::size_t RawlogReader::countFrames(const fs::path& rawlogPath) {
  auto objects = openRawlog(rawlogPath);
  std::size_t n = 0;
  while (auto obj = objects->next(n)) {
    auto obs = std::dynamic_pointer_cast<mrpt::obs::CObservation>(obj);
    if (obs && obs->sensorLabel == kCameraLabel) ++n;
  }
  return n;
}

}  // namespace pslam::datasets
