#include "pslam/landmarks/MeasurementVariance.h"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

#include "pslam/core/Error.h"

namespace pslam::landmarks {

DepthUncertainty depthUncertainty(const Eigen::Vector3d& bearingRef, double range, const Eigen::Vector3d& t_ref_cur,
                                  double focalLength, double pixelNoise) {
  if (!(bearingRef.allFinite() && std::abs(bearingRef.norm() - 1.0) < 1e-6))
    throw Error("depthUncertainty: bearing must be a finite unit vector");
  if (!(std::isfinite(range) && range > 0)) throw Error("depthUncertainty: range must be finite and > 0");
  if (!(std::isfinite(focalLength) && focalLength > 0)) throw Error("depthUncertainty: focal length must be > 0");
  if (!(std::isfinite(pixelNoise) && pixelNoise > 0)) throw Error("depthUncertainty: pixel noise must be > 0");
  const double baseline = t_ref_cur.norm();
  if (!(std::isfinite(baseline) && baseline > 0)) throw Error("depthUncertainty: zero or non-finite baseline");

  DepthUncertainty out;
  const Eigen::Vector3d X = bearingRef * range;  // point in the reference frame
  const Eigen::Vector3d a = X - t_ref_cur;       // eq. 2.24: ray from the current centre to the point
  const double aNorm = a.norm();
  if (!(aNorm > 0)) return out;
  // Angles of the triangle (reference centre, current centre, point); clamped against acos domain errors.
  const double alpha = std::acos(std::clamp(bearingRef.dot(t_ref_cur) / baseline, -1.0, 1.0));        // eq. 2.24
  const double beta = std::acos(std::clamp(-a.dot(t_ref_cur) / (aNorm * baseline), -1.0, 1.0));      // eq. 2.25
  const double betaPlus = std::atan(pixelNoise / focalLength);  // eq. 2.26 (1 pixel there)
  const double gamma = M_PI - alpha - (beta + betaPlus);         // eq. 2.27
  if (!(gamma > 1e-12)) return out;
  // eq. 2.28 by the law of sines in the perturbed triangle: |X+| / sin(beta + beta+) = |t| / sin(gamma).
  const double rangePlus = baseline * std::sin(beta + betaPlus) / std::sin(gamma);
  out.tauRange = rangePlus - range;  // eq. 2.29: sigma = |X+| - |X|
  // Inverse depth along z (eq. 3.1): z = range * bearing_z; half the width of the inverse-depth interval that
  // the depth interval [z - tau_z, z + tau_z] maps to (as SVO).
  const double z = range * bearingRef.z();
  const double tauZ = out.tauRange * bearingRef.z();
  if (!(z > 0 && tauZ > 0 && tauZ < z)) {
    out.tauRange = 0.0;
    return out;
  }
  out.tauInverseDepth = 0.5 * (1.0 / (z - tauZ) - 1.0 / (z + tauZ));
  out.valid = std::isfinite(out.tauInverseDepth) && out.tauInverseDepth > 0;
  return out;
}

}  // namespace pslam::landmarks
