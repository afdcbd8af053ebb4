// Accuracy of the two-view initializer over many synthetic scenes, per configuration: ORB-SLAM's
// behaviour (pose from the best 8-point hypothesis), + least-squares refit on the inliers, + Sampson
// refinement (the default). Prints one line per (scene, mode) and the failure reasons.
// Usage: bench_two_view_accuracy [numSeeds] [baselineScale] [noisePx]
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "SyntheticScene.h"
#include "pslam/geometry/TwoViewInitializer.h"

using namespace pslam::geometry;
using namespace pslam::geometry::test;

int main(int argc, char** argv) {
  const int numSeeds = argc > 1 ? std::atoi(argv[1]) : 20;
  const double baselineScale = argc > 2 ? std::atof(argv[2]) : 1.0;
  const double noisePx = argc > 3 ? std::atof(argv[3]) : 0.8;
  std::printf("general t = (0.5, 0.08, 0.1) * %.2f, planar t = (0.6, 0, 0.05) * %.2f, noise %.2f px, 20 %% outliers\n",
              baselineScale, baselineScale, noisePx);
  const Eigen::Matrix3d R = rotationFromAxisAngle({0.2, 1.0, 0.1}, 4.0);
  struct Mode {
    const char* name;
    int refit;
    bool refine;
  };
  const Mode modes[] = {{"orbslam", 0, false}, {"refit", 2, false}, {"refit+sampson", 2, true}};
  std::printf("%-8s %-14s %5s %9s %9s %9s %9s %8s\n", "scene", "mode", "ok", "rotMean", "rotMax", "dirMean", "dirMax",
              "modelOK");
  for (const SceneShape shape : {SceneShape::General, SceneShape::Planar}) {
    const bool general = shape == SceneShape::General;
    const Eigen::Vector3d t =
        baselineScale * (general ? Eigen::Vector3d(0.5, 0.08, 0.1) : Eigen::Vector3d(0.6, 0.0, 0.05));
    // (the unit tests use baselineScale 2: general (1.0, 0.16, 0.2), planar (1.2, 0, 0.1))
    for (const Mode& mode : modes) {
      TwoViewParams params;
      params.refitIterations = mode.refit;
      params.refinePose = mode.refine;
      const TwoViewInitializer init(testCamera(), params);
      int ok = 0, modelOk = 0;
      std::string failures;
      double rotSum = 0, rotMax = 0, dirSum = 0, dirMax = 0;
      for (int seed = 1; seed <= numSeeds; ++seed) {
        const TwoViewScene s = makeScene(shape, R, t, 400, noisePx, 0.2, 1000 + seed);
        std::mt19937 rng(seed);
        const TwoViewResult r = init.initialize(s.pixels_ref, s.pixels_cur, rng);
        modelOk += r.model == (general ? TwoViewModel::Fundamental : TwoViewModel::Homography) ? 1 : 0;
        if (!r.success) {
          failures += std::string(" [seed ") + std::to_string(seed) + ": " + toString(r.failure) + "]";
          continue;
        }
        ++ok;
        const double rot = rotationErrorDeg(r.R_cur_ref, R), dir = directionErrorDeg(r.t_cur_ref, t);
        rotSum += rot;
        dirSum += dir;
        rotMax = std::max(rotMax, rot);
        if (std::getenv("PSLAM_VERBOSE")) std::printf("  seed %d: rot %.3f dir %.3f | %s\n", seed, rot, dir, r.message.c_str());
        dirMax = std::max(dirMax, dir);
      }
      std::printf("%-8s %-14s %2d/%-2d %9.3f %9.3f %9.3f %9.3f %5d/%-2d%s\n", general ? "general" : "planar", mode.name,
                  ok, numSeeds, ok ? rotSum / ok : 0.0, rotMax, ok ? dirSum / ok : 0.0, dirMax, modelOk, numSeeds,
                  failures.c_str());
    }
  }
  return 0;
}
