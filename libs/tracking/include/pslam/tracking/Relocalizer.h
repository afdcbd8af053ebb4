#pragma once
// Place recognition in tracking (thesis §2.4.1, doc/places.md): the keyframes' and frames' bag-of-words vectors in
// the run's vocabulary, the keyframe database, and relocalization (ORB-SLAM's Relocalization: candidate keyframes
// from the database, matched by vocabulary node, PnP RANSAC, pose optimization, a wider projection search when the
// inliers are few). Without a vocabulary, every keyframe is a candidate, matched exhaustively.
#include <memory>
#include <utility>
#include <vector>

#include "pslam/places/KeyFrameDatabase.h"
#include "pslam/places/PlacesParams.h"
#include "pslam/places/Vocabulary.h"
#include "pslam/tracking/FramePoseOptimizer.h"
#include "pslam/tracking/Frame.h"
#include "pslam/tracking/TrackingContext.h"

namespace pslam::tracking {

class Relocalizer {
 public:
  Relocalizer(TrackingContext& context, FramePoseOptimizer& optimizer) : ctx_(context), optimizer_(optimizer) {}

  /// The vocabulary (null: none, exhaustive matching). The keyframes already in the map get their BoW now.
  void setVocabulary(std::shared_ptr<const places::Vocabulary> vocabulary, const places::PlacesParams& params);
  const std::shared_ptr<const places::Vocabulary>& vocabulary() const { return vocabulary_; }
  const places::PlacesParams& placesParams() const { return placesParams_; }

  /// BoW vector and direct index of keyframe `id`, when it has none yet (and there is a vocabulary).
  void computeKeyFrameBow(map::KeyFrameId id);
  /// Same for a frame (once per frame).
  void computeFrameBow(Frame& frame) const;
  /// Forgets the keyframe database (a new or loaded map); the keyframes of the map get their BoW again.
  void onMapReplaced();
  void clear() { keyFrameDatabase_.clear(); }

  /// Relocalizes `frame` against the map: true with its pose, matches and the reference keyframe set.
  bool relocalize(Frame& frame);

 private:
  struct Candidate {
    map::KeyFrameId kf;
    std::vector<std::pair<std::size_t, map::MapPointId>> matches;  ///< frame keypoint -> point
  };
  /// The candidates with their descriptor matches, most matches first, at most relocalizationCandidates.
  std::vector<Candidate> candidates(Frame& frame);
  /// The keyframe database holds exactly the map's keyframes (new ones added, culled ones erased).
  void syncKeyFrameDatabase();

  TrackingContext& ctx_;
  FramePoseOptimizer& optimizer_;
  std::shared_ptr<const places::Vocabulary> vocabulary_;
  places::PlacesParams placesParams_;
  places::KeyFrameDatabase keyFrameDatabase_;
};

}  // namespace pslam::tracking
