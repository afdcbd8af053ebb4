#pragma once
// The rawlog contract (doc/architecture.md, "Data contracts"): an observation-only MRPT rawlog (gz), images stored externally as
// lossless files in `<name>_Images/`. One frame = a CAMERA observation followed by the optional DEPTH,
// SEMANTIC and NORMALS observations that share its timestamp.
//
// Channel layout in memory (cv::Mat channel index; in PNG files OpenCV stores index 0 as blue):
//   SEMANTIC: channel k = round(255 * P(class k)), k = 0 static, 1 dynamic, 2 invalid (Table 3.1).
//   NORMALS : channel k = round((n_k + 1) / 2 * 255) of the unit camera-frame normal (x right, y down,
//             z forward); (0,0,0) = no normal / not planar.
//   DEPTH   : CV_16UC1, depth along the optical axis = value * depthUnits metres, 0 = invalid.
#include <cstddef>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include <mrpt/img/TCamera.h>
#include <mrpt/poses/CPose3D.h>
#include <opencv2/core.hpp>

#include "pslam/core/AtomicFile.h"

namespace pslam::datasets {

inline constexpr const char* kCameraLabel = "CAMERA";
inline constexpr const char* kDepthLabel = "DEPTH";
inline constexpr const char* kSemanticLabel = "SEMANTIC";
inline constexpr const char* kNormalsLabel = "NORMALS";

/// Semantic classes of the SEMANTIC channel (Table 3.1 grouping).
enum class SemanticClass : int { Static = 0, Dynamic = 1, Invalid = 2 };

struct Frame {
  std::size_t index = 0;     ///< 0-based position in the rawlog (set by the reader)
  double timestamp = 0.0;    ///< seconds
  cv::Mat image;             ///< CV_8UC1 (grey) or CV_8UC3 (BGR)
  mrpt::img::TCamera camera; ///< intrinsics + distortion of `image`
  mrpt::poses::CPose3D sensorPoseOnBody;  ///< CAMERA pose on the vehicle/body (identity if unknown)
  cv::Mat depth;             ///< CV_16UC1 registered to `image`, or empty
  double depthUnits = 0.0;   ///< metres per depth unit (TUM: 1/5000)
  cv::Mat semantic;          ///< CV_8UC3 or empty
  cv::Mat normals;           ///< CV_8UC3 or empty

  bool hasDepth() const { return !depth.empty(); }
  bool hasSemantic() const { return !semantic.empty(); }
  bool hasNormals() const { return !normals.empty(); }
};

/// Checks a frame against the contract (types, sizes, intrinsics, finite timestamp). Throws pslam::Error
/// with `context` (e.g. "dataset frame 12") in the message.
void validateFrame(const Frame& frame, const std::string& context);

/// Encodes / decodes one camera-frame unit normal as NORMALS pixel values.
cv::Vec3b encodeNormal(const cv::Vec3d& n);
/// Returns false for the (0,0,0) "no normal" pixel.
bool decodeNormal(const cv::Vec3b& px, cv::Vec3d& n);

/// Writes frames to `<path>` and their images to `<stem>_Images/`. Nothing appears under the final names
/// until commit(): a writer destroyed without commit() removes its temporary files. An existing rawlog is
/// replaced; an existing images folder only if it holds nothing but images this writer names
/// (imagesFolderKind()), checked when the writer is made.
class RawlogWriter {
 public:
  /// imageExtension: "png" (default, lossless) or "bmp"/"tiff"/"ppm" (lossless); "jpg" is refused.
  /// With `outputs`, the images folder and the rawlog are prepared in that set (so checked against its inputs
  /// and committed with the tool's other outputs by OutputSet::commit()); commit() then only closes the file.
  explicit RawlogWriter(std::filesystem::path rawlogPath, std::string imageExtension = "png",
                        OutputSet* outputs = nullptr);
  ~RawlogWriter();
  RawlogWriter(const RawlogWriter&) = delete;
  RawlogWriter& operator=(const RawlogWriter&) = delete;

  /// Validates and appends one frame. Every frame must have the image size of the first one.
  void write(const Frame& frame);
  std::size_t framesWritten() const { return frames_; }
  /// Closes the archive and moves rawlog and images folder into place.
  void commit();

  /// `<dir>/<stem>_Images` for a rawlog path.
  static std::filesystem::path imagesDirFor(const std::filesystem::path& rawlogPath);
  /// The images folder as an output: the files `<LABEL>_<frame>.<ext>` this writer names.
  static OutputKind imagesFolderKind();
  /// A rawlog and its images folder: what a tool that reads the rawlog lists as its inputs.
  static std::vector<std::filesystem::path> inputFilesOf(const std::filesystem::path& rawlogPath);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::size_t frames_ = 0;
};

/// The channels a reader decodes besides CAMERA. A channel left out is still checked for its observation kind
/// but not decoded (its image file is not read): the Frame has it empty. A run that does not use a channel saves
/// its decoding (PNG for SEMANTIC and NORMALS, the range image for DEPTH).
struct RawlogChannels {
  bool depth = true;
  bool semantic = true;
  bool normals = true;
};

/// The order of the frames' stamps. strict: each frame's stamp must be after the previous one's (a stamp going
/// back or repeated is an error naming the frame). sort: the frames' observations are read first and given in
/// stamp order (repeated stamps in the rawlog's order), with a warning (warnings()); costs the memory of every
/// observation (images stay in their files).
enum class StampOrder { strict, sort };

/// Streams frames from a rawlog that follows the contract. Images are loaded one frame at a time. The gzip
/// stream is verified to its end (pslam::GzipInputStream): corrupt or cut data is an error naming the file and
/// the frame, never the end of the rawlog.
class RawlogReader {
 public:
  /// Throws pslam::Error if the file is missing or cannot be opened.
  explicit RawlogReader(std::filesystem::path rawlogPath, RawlogChannels channels = {},
                        StampOrder order = StampOrder::strict);
  ~RawlogReader();
  RawlogReader(const RawlogReader&) = delete;
  RawlogReader& operator=(const RawlogReader&) = delete;

  /// Reads the next frame; returns false at the end. Throws pslam::Error naming the rawlog and the frame on
  /// a corrupt archive, a missing image file, a channel without a CAMERA, or a size mismatch.
  bool next(Frame& frame);
  const std::filesystem::path& path() const;
  const std::filesystem::path& imagesDir() const;
  /// What StampOrder::sort changed, one line each naming the file (empty otherwise).
  const std::vector<std::string>& warnings() const;

  /// Counts the frames (reads and verifies the whole archive without loading the images).
  static std::size_t countFrames(const std::filesystem::path& rawlogPath);

 private:
  bool readFrame(Frame& frame);
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pslam::datasets
