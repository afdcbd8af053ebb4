#pragma once
// The map-point model of a SLAM run, one section [PointModel] (doc/semantic_model.md): which model
// (heuristic = ORB-SLAM*, masking, probabilistic; Table 3.3), ORB-SLAM's culling constants, the keypoint model
// of §3.3 and the matching accuracies of §3.2. Script-stable: `--set PointModel.model=probabilistic`.
#include "pslam/core/Params.h"
#include "pslam/landmarks/KeypointModel.h"
#include "pslam/landmarks/MapPointPolicy.h"
#include "pslam/landmarks/MatchingAccuracy.h"

namespace pslam::landmarks {

struct PointModelParams {
  /// Default heuristic: a SLAM run is ORB-SLAM* unless the config names a chapter-3 model.
  MapPointPolicyParams policy = [] {
    MapPointPolicyParams p;
    p.model = MapPointModel::Heuristic;
    return p;
  }();
  KeypointModelParams keypoint;    ///< used by the masking and probabilistic models
  MatchingAccuracyParams matching;
  /// The SEMANTIC channel is the class evidence of the points (eq. 3.10). false, or a frame without the
  /// channel: every keypoint counts as observed static (the segmentation that trusts everything), so the
  /// geometric evidence alone decides.
  bool semantic = true;

  /// Keys: model, minFoundRatio, ... (policy), initialCount, psiMin, A_static, ... (keypoint),
  /// hammingMaxDistance, photometricMaxSsd (matching), semantic: all flat.
  template <class V>
  void visitFields(V& v) {
    v.flat(policy);
    v.flat(keypoint);
    v.flat(matching);
    PSLAM_FIELD(v, semantic, params::anyValue, "use the SEMANTIC channel as class prior (false: all static)");
  }
  PSLAM_PARAMS("PointModel")
};

}  // namespace pslam::landmarks
