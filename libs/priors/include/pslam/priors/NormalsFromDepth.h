#pragma once
// Normals and a planar mask from a depth image: the thesis' "-w AHC" configuration (§4.5.4, Tables 4.3/4.4),
// where normals extracted from sensor depth by plane clustering serve as the most accurate normal prior.
//
// Two stages:
//  1. per-pixel normals by local PCA over a box window, computed with box-filtered moment images (sums of
//     p and p p^T over the valid pixels of the window); pixels whose window reaches a depth discontinuity
//     (distance transform of the jump edges) get no normal, nor do windows with too few valid pixels or a
//     high surface variation lambda_min / trace (folds between planes, clutter);
//  2. plane segmentation in the spirit of AHC (Feng et al., ICRA 2014): the image is cut into cells, a plane
//     is fitted per cell, cells whose fit error exceeds the sensor noise at their depth are discarded, and
//     the remaining cells are merged region by region (best-fitting cell first) while the merged plane still
//     fits within the noise and the normals agree. Regions large enough are planes; their pixels near the
//     plane form the planar mask and (optionally) receive the plane normal.
#include <cmath>
#include <string>

#include <mrpt/config/CConfigFileBase.h>
#include <mrpt/img/TCamera.h>
#include <opencv2/core.hpp>

#include "pslam/core/Params.h"
#include "pslam/priors/NormalMap.h"

namespace pslam::priors {

struct DepthNormalParams {
  double minDepth = 0.1;
  double maxDepth = 8.0;
  int windowRadius = 5;
  /// Neighbouring depths differing by more than this share of the depth are a discontinuity; pixels whose
  /// PCA window would reach across one get no normal (the window would mix two surfaces).
  double maxDepthJumpRatio = 0.03;
  double minWindowValidShare = 0.6;
  double maxCurvature = 0.05;
  int cellSize = 10;
  double minCellValidShare = 0.8;
  /// Sensor depth noise model sigma(z) = noiseQuadratic * z^2 + noiseConstant [m] (Kinect-like, as in AHC).
  double noiseQuadratic = 0.0016;
  double noiseConstant = 0.002;
  double cellMseFactor = 1.0;
  double mergeMseFactor = 2.0;
  double mergeAngleDeg = 15.0;
  int minPlaneCells = 40;
  /// Pixels of a plane's cells within this many sigma(z) are planar, and whose own PCA normal (when it has
  /// one) is within mergeAngleDeg of the plane normal.
  double inlierSigmas = 3.0;
  bool usePlaneNormals = true;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, minDepth, atLeast(0), "[m] closer depths are invalid");
    PSLAM_FIELD(v, maxDepth, satisfies([this](double d) { return std::isfinite(d) && d > minDepth; }, "must be > minDepth"),
                "[m] farther depths are invalid");
    PSLAM_FIELD(v, windowRadius, inClosed(1, 50), "[px] PCA window is (2r+1)^2");
    PSLAM_FIELD(v, maxDepthJumpRatio, greaterThan(0), "depth discontinuity as a share of the depth");
    PSLAM_FIELD(v, minWindowValidShare, inLeftOpen(0, 1), "share of valid pixels a PCA window needs");
    PSLAM_FIELD(v, maxCurvature, satisfies([](double c) { return c > 0 && c <= 1.0 / 3.0; }, "must be in (0, 1/3]"),
                "lambda_min / trace above this = edge or clutter, no normal");
    PSLAM_FIELD(v, cellSize, inClosed(3, 100), "[px] AHC cell side");
    PSLAM_FIELD(v, minCellValidShare, inLeftOpen(0, 1), "share of valid pixels a cell needs");
    PSLAM_FIELD(v, noiseQuadratic, atLeast(0), "sigma(z) = noiseQuadratic * z^2 + noiseConstant [m]");
    PSLAM_FIELD(v, noiseConstant, greaterThan(0), "see noiseQuadratic");
    PSLAM_FIELD(v, cellMseFactor, greaterThan(0), "a cell is planar if its plane RMS error <= factor * sigma(z)");
    PSLAM_FIELD(v, mergeMseFactor, greaterThan(0), "a merge is accepted if the merged RMS error <= factor * sigma(z)");
    PSLAM_FIELD(v, mergeAngleDeg, inOpen(0, 90), "a merge needs cell and region normals within this angle");
    PSLAM_FIELD(v, minPlaneCells, atLeast(1), "regions with fewer cells are not planes");
    PSLAM_FIELD(v, inlierSigmas, greaterThan(0), "plane pixels within this many sigma(z) are planar");
    PSLAM_FIELD(v, usePlaneNormals, anyValue, "planar pixels get the plane normal instead of the PCA normal");
  }
  PSLAM_PARAMS("NormalsFromDepth")
};

/// Pinhole intrinsics of the depth image (registered to the camera; distortion is not modelled).
struct PinholeIntrinsics {
  double fx = 0, fy = 0, cx = 0, cy = 0;
  static PinholeIntrinsics fromCamera(const mrpt::img::TCamera& camera);
};

class DepthNormalEstimator {
 public:
  explicit DepthNormalEstimator(DepthNormalParams params = {});
  const DepthNormalParams& params() const { return params_; }

  /// depthMetres: CV_32FC1, metres along the optical axis, 0 or NaN = invalid.
  NormalMap compute(const cv::Mat& depthMetres, const PinholeIntrinsics& K) const;
  /// depth: CV_16UC1 raw sensor units (value * depthUnits = metres), as in the DEPTH channel.
  NormalMap computeFromRaw(const cv::Mat& depth, double depthUnits, const PinholeIntrinsics& K) const;

 private:
  DepthNormalParams params_;
};

}  // namespace pslam::priors
