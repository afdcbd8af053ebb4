#pragma once
// [Places]: the bag-of-words vocabulary of a SLAM run and where tracking and mapping use it (doc/places.md).
#include <string>

#include "pslam/core/Params.h"

namespace pslam::places {

struct PlacesParams {
  /// The .pvoc file (vocab-train); a relative path is relative to the folder of the config file that sets it.
  /// Empty: no vocabulary (relocalization, reference tracking and triangulation match without it).
  std::string vocabulary;
  /// Level of the direct index, counted up from the leaves (ORB-SLAM: 4 on its depth-6 tree, i.e. level 2).
  int directIndexLevelsUp = 3;
  bool relocalization = true;     ///< relocalization candidates from the keyframe database, matched by node
  /// Reference-keyframe tracking matched by node (ORB-SLAM's SearchByBoW). Off by default: it is used about once per
  /// run (the frame after initialization), and its fewer matches moved single runs both ways (doc/places.md).
  bool referenceTracking = false;
  /// Triangulation candidates restricted to the keypoint's node: off by default, because the fewer matches make
  /// more keyframes and more local BA than the node search saves (doc/places.md).
  bool triangulation = false;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, vocabulary, anyValue, ".pvoc vocabulary (relative to the config file); empty = none");
    PSLAM_FIELD(v, directIndexLevelsUp, inClosed(0, 8), "direct-index level, counted up from the leaves");
    PSLAM_FIELD(v, relocalization, anyValue, "relocalization by the keyframe database and node-guided matching");
    PSLAM_FIELD(v, referenceTracking, anyValue, "reference-keyframe tracking by node-guided matching");
    PSLAM_FIELD(v, triangulation, anyValue, "triangulation candidates restricted to the same vocabulary node");
  }
  PSLAM_PARAMS("Places")
};

}  // namespace pslam::places
