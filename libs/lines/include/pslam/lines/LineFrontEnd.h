#pragma once
// Line segments in the running system (thesis §2.3.2.2, §2.4.4 PL-SLAM, §4.4, Table 4.1), a front end beside the
// keypoints exactly as the direct points are (pslam::direct::DirectFrontEnd):
//   - extraction (LineExtractor): LSD on one level, the 40 longest segments, LBD descriptors, undistorted
//     endpoints, once per frame (prepareFrame) and kept per keyframe;
//   - tracking (a tracking::LandmarkModule): the map lines in front of the frame at its pose estimate are projected and
//     matched by projection + LBD (LineMatching.h); each match is a LinePoseFactor (eq. 2.59) of the frame's pose
//     optimization; afterwards its inlier flag counts into the line's found / visible ratio, and the inlier
//     matches of a frame that becomes a keyframe are that keyframe's observations;
//   - mapping (createLines, at each new keyframe): unmatched segments of the keyframe matched by descriptor with
//     the unmatched segments of its covisible keyframes and triangulated (plane intersection, LineGeometry.h);
//     a descriptor match with a segment that already observes a line adds the keyframe's observation of it when
//     its reprojection passes the chi-square test;
//   - local BA (bundleAdjustmentFactors / afterBundleAdjustment): every line with two or more observations in
//     the window joins with a LineBAFactor per observation; outlier observations are erased;
//   - culling: lines whose found ratio in pose optimization falls below cullMinFoundRatio, and lines that no
//     keyframe observed again within probationKeyFrames keyframes of their creation.
// Lines live in this store next to the map; map.slammap carries it as the map extension "lines" (serialize /
// restore). Everything is deterministic (ordered containers, no randomness).
#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "pslam/core/Params.h"
#include "pslam/geometry/PinholeCamera.h"
#include "pslam/lines/LineExtractor.h"
#include "pslam/lines/LineFactors.h"
#include "pslam/lines/LineGeometry.h"
#include "pslam/lines/LineMatching.h"
#include "pslam/map/Map.h"
#include "pslam/optimize/BundleAdjustment.h"
#include "pslam/tracking/LandmarkModule.h"

namespace pslam::lines {

/// [Lines]: line segments in tracking and local BA (off by default).
struct LinesParams {
  bool enabled = false;
  LineExtractorParams extractor;
  // Tracking: matching by projection
  int maxHamming = 60;            ///< LBD distance of a match (of 256 bits)
  double ratio = 0.85;            ///< best < ratio * second best
  double maxAngleDeg = 10.0;      ///< projected map line vs segment
  double maxDistance = 15.0;      ///< px, the segment's endpoints from the projected line
  double minOverlap = 0.2;        ///< common part / shorter segment
  int minTrackingInliers = 20;    ///< line inliers that would carry a pose alone (share in the success rule)
  // Mapping
  int triangulationNeighbours = 5;  ///< covisible keyframes matched with a new keyframe
  double minPlaneAngleDeg = 1.0;    ///< parallax: angle between the two back-projected planes
  double maxDepthRatio = 40.0;      ///< endpoint depth at most this many baselines
  int probationKeyFrames = 3;       ///< a line needs ...
  int minObservations = 3;          ///< ... this many keyframe observations that many keyframes after creation
  int cullMinVisible = 5;           ///< pose optimizations before the found ratio is checked
  double cullMinFoundRatio = 0.25;  ///< inliers / entries of pose optimization below this: culled
  bool localBundleAdjustment = true;
  int maxBaLines = 200;             ///< lines in one local BA (evenly thinned beyond)

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, enabled, anyValue, "line segments in tracking and local BA (§2.4.4, eq. 2.59)");
    v.flat(extractor);
    PSLAM_FIELD(v, maxHamming, inClosed(0, 256), "LBD Hamming distance of a line match");
    PSLAM_FIELD(v, ratio, inLeftOpen(0, 1), "ratio test: best < ratio * second best");
    PSLAM_FIELD(v, maxAngleDeg, inOpen(0, 90), "projected map line vs segment direction (degrees)");
    PSLAM_FIELD(v, maxDistance, greaterThan(0), "segment endpoints from the projected line (pixels)");
    PSLAM_FIELD(v, minOverlap, inClosed(0, 1), "overlap of projected line and segment (fraction of the shorter)");
    PSLAM_FIELD(v, minTrackingInliers, atLeast(1), "line inliers that carry a pose alone");
    PSLAM_FIELD(v, triangulationNeighbours, atLeast(1), "covisible keyframes a new keyframe triangulates with");
    PSLAM_FIELD(v, minPlaneAngleDeg, inOpen(0, 90), "minimum angle between the two back-projected planes");
    PSLAM_FIELD(v, maxDepthRatio, greaterThan(0), "endpoint depth at most this many baselines");
    PSLAM_FIELD(v, probationKeyFrames, atLeast(1), "keyframes after creation before the observation check");
    PSLAM_FIELD(v, minObservations, atLeast(2), "keyframe observations a line needs after its probation");
    PSLAM_FIELD(v, cullMinVisible, atLeast(1), "pose optimizations before the found ratio is checked");
    PSLAM_FIELD(v, cullMinFoundRatio, inClosed(0, 1), "cull below this ratio of pose inliers");
    PSLAM_FIELD(v, localBundleAdjustment, anyValue, "lines in local BA");
    PSLAM_FIELD(v, maxBaLines, atLeast(0), "lines in one local BA");
  }
  PSLAM_PARAMS("Lines")

  LineMatchParams trackingMatch() const { return {maxHamming, ratio, maxAngleDeg, maxDistance, minOverlap}; }
};

/// What the lines did in one frame (report.json "frames": lines_detected, lines_visible, lines_factors,
/// lines_inliers).
struct LineFrameCounts {
  int detected = 0;  ///< segments extracted from the frame
  int visible = 0;   ///< map lines projected into the frame at the last lineFactors() call
  int factors = 0;   ///< matched lines that entered the frame's last pose optimization
  int inliers = 0;   ///< ... that passed its chi-square test (5.991)
  nlohmann::json toJson() const;
};

/// One map line: world endpoints (the BA block), the descriptor of its latest keyframe observation, the keyframe
/// observations (keyframe -> segment index there) and the pose-optimization counters.
struct MapLine {
  std::shared_ptr<LineLandmark> landmark;
  cv::Mat descriptor;
  std::map<map::KeyFrameId, int> observations;
  std::uint64_t createdAt = 0;  ///< keyframes registered (addKeyFrame count) when it was made
  std::uint32_t visible = 0;    ///< pose optimizations it entered
  std::uint32_t found = 0;      ///< ... as an inlier
  bool bad = false;
};

/// The segments of one keyframe and which map line each observes (-1: none).
struct LineKeyFrame {
  LineFeatures features;
  std::vector<long long> lineIds;
};

/// What createLines() did for one keyframe (mapping log).
struct LineCreationReport {
  int candidates = 0;  ///< descriptor matches tried
  int created = 0;
  int fused = 0;       ///< observations of existing lines added
  int culled = 0;
  double ms = 0.0;
};

class LineFrontEnd : public tracking::LandmarkModule {
 public:
  /// Checks `params` (pslam::Error naming the key).
  LineFrontEnd(const LinesParams& params, const geometry::PinholeCamera& camera);

  // ---- tracking::LandmarkModule ----
  std::string name() const override { return "line"; }
  /// LSD + LBD of the frame (stage "line_extraction").
  void prepareFrame(const tracking::Frame& frame, StageTimings& timings) override;
  /// The point-to-line factors of lineFactors().
  tracking::ModulePoseFactors poseFactors(const tracking::Frame& frame, const map::Map& map,
                                          map::KeyFrameId reference) override;
  int minInliers() const override { return params_.minTrackingInliers; }
  tracking::ModuleFrameReport afterTracking(const tracking::Frame& frame, const map::Map& map,
                                            const std::vector<bool>& factorOutliers, bool learn) override;
  void addKeyFrame(const tracking::KeyFrameImages& keyFrame) override;
  /// New lines of the keyframe (createLines), then prune.
  void afterLocalMapping(const map::Map& map, map::KeyFrameId kf, StageTimings& timings, nlohmann::json& log) override;
  /// LineBAFactors of the lines with two or more observations in the window.
  std::vector<std::shared_ptr<optimize::BAFactor>> bundleAdjustmentFactors(const map::Map& map,
                                                                          const optimize::BAProblem& problem) override;
  void afterBundleAdjustment(const std::vector<bool>& factorOutliers) override {
    applyBundleAdjustment(factorOutliers);
  }
  void reset() override;
  std::map<std::string, std::size_t> counts() const override;
  std::string mapExtensionName() const override { return kMapExtension; }
  std::optional<std::string> mapExtension() const override;
  std::function<void()> prepareLoad(const std::string& bytes, const map::Map& loaded) override;

  // ---- tracking, as the module's stages call it ----
  /// Extracts the segments of `frame` (its grey image) once; lineFactors() does it when not done yet.
  void prepareFrame(const tracking::Frame& frame);
  /// Point-to-line factors (eq. 2.59) of the map lines matched in `frame` at its current pose estimate; empty when
  /// there are none.
  std::vector<std::shared_ptr<const optimize::PoseFactor>> lineFactors(const tracking::Frame& frame);
  /// The frame was tracked (final pose in frame.T_cam_world); `factorOutliers` per factor of the last
  /// lineFactors() call in the last pose optimization (empty when the lines did not take part): the lines'
  /// found / visible counters and culling. Returns the frame's counts.
  LineFrameCounts afterTracking(const tracking::Frame& frame, const std::vector<bool>& factorOutliers);

  // ---- mapping ----
  /// Registers keyframe `kf`: the segments of the frame last prepared and its inlier matches when
  /// `fromLastFrame`, else the segments of `grey` (no observations).
  void addKeyFrame(map::KeyFrameId kf, const cv::Mat& grey, bool fromLastFrame);
  /// New lines of keyframe `kf` with its covisible keyframes (and observations of existing lines), then culling.
  LineCreationReport createLines(const map::Map& map, map::KeyFrameId kf);
  /// After local BA: observations whose factor is an outlier are erased. Returns the lines refined.
  int applyBundleAdjustment(const std::vector<bool>& factorOutliers);
  /// Drops keyframes that left the map (and their observations) and erases bad lines.
  void prune(const map::Map& map);

  /// Lines that are not bad.
  std::size_t numLines() const;
  const std::map<std::uint64_t, MapLine>& lines() const { return lines_; }
  const std::map<map::KeyFrameId, LineKeyFrame>& keyFrames() const { return keyframes_; }
  /// Milliseconds of the last prepareFrame() extraction (LSD + LBD).
  double lastExtractionMs() const { return extractionMs_; }
  const LinesParams& params() const { return params_; }
  // ---- saved with the map (Map extension "lines", format in LineStoreIO.cpp) ----
  /// The line store (keyframe segments and descriptors, lines with their observations and counters) as bytes.
  std::string serialize() const;
  /// Replaces the store by one serialize() wrote, for `map` (a loaded map): every keyframe must be one of the map's,
  /// every observation and segment index consistent. Throws pslam::Error saying what is wrong ("lines: ...") and
  /// leaves the store empty then.
  void restore(const std::string& bytes, const map::Map& map);
  /// What serialize() wrote, checked as restore() checks it, without a front end (loading checks a map's store
  /// before it replaces anything, then installs the parsed store).
  struct Store {
    std::map<std::uint64_t, MapLine> lines;
    std::map<map::KeyFrameId, LineKeyFrame> keyframes;
    std::uint64_t nextId = 0;
    std::uint64_t keyframesAdded = 0;
  };
  static Store parse(const std::string& bytes, const map::Map& map);
  /// Replaces the store by one parse() returned (its keyframes must be in the map the front end tracks in).
  void restore(Store store);
  static constexpr const char* kMapExtension = "lines";

  /// Adds a line (tests): world endpoints, descriptor, observations (keyframe -> segment). Returns its id.
  std::uint64_t addLine(const Line3& line, const cv::Mat& descriptor, const std::map<map::KeyFrameId, int>& observations);

 private:
  void addObservation(std::uint64_t id, map::KeyFrameId kf, int segment);
  void eraseObservation(std::uint64_t id, map::KeyFrameId kf);
  bool inFront(const Line3& line, const Eigen::Isometry3d& T_cam_world) const;

  LinesParams params_;
  geometry::PinholeCamera intrinsics_;
  LineExtractor extractor_;
  std::map<std::uint64_t, MapLine> lines_;
  std::map<map::KeyFrameId, LineKeyFrame> keyframes_;
  std::uint64_t nextId_ = 0;
  std::uint64_t keyframesAdded_ = 0;

  // The frame last prepared
  std::size_t frameIndex_ = static_cast<std::size_t>(-1);
  double frameTimestamp_ = 0.0;
  bool framePrepared_ = false;
  LineFeatures frameFeatures_;
  double extractionMs_ = 0.0;
  std::vector<std::pair<std::uint64_t, int>> lastFactors_;  ///< (line, segment) per factor of the last poseFactors()
  int lastVisible_ = 0;
  std::vector<long long> frameMatches_;  ///< per frame segment: the line of its inlier match after tracking, or -1
  std::vector<std::pair<std::uint64_t, map::KeyFrameId>> baFactors_;  ///< per factor of bundleAdjustmentFactors()
};

}  // namespace pslam::lines
