#pragma once
// Measurement variance tau^2 of one triangulated depth (eq. 2.24-2.29, the fixed angular error model of SVO
// [23]): the bearing of the new view is perturbed by the angle of `pixelNoise` pixels and the depth change of
// the triangulated point along the reference ray is the standard deviation. Expressed for the inverse depth
// along the z axis of the reference camera (the parameterization of eq. 3.1).
#include <Eigen/Core>

namespace pslam::landmarks {

struct DepthUncertainty {
  bool valid = false;            ///< false: no usable triangulation (parallax below the pixel angle)
  double tauRange = 0.0;         ///< std-dev of the distance |X| along the reference bearing (eq. 2.29: sigma)
  double tauInverseDepth = 0.0;  ///< std-dev of the inverse z-depth
  double tau2InverseDepth() const { return tauInverseDepth * tauInverseDepth; }
};

/// bearingRef: unit bearing of the point in the reference camera; range: |X| (distance from the reference
/// centre along the bearing); t_ref_cur: position of the current camera centre in the reference frame;
/// focalLength in pixels; pixelNoise in pixels (eq. 2.26 uses 1). Throws pslam::Error on a zero baseline,
/// non-positive range / focal / noise, or a non-unit bearing. Returns valid = false (and zeros, never Inf)
/// when the perturbed rays no longer intersect in front of the camera or tau exceeds the depth itself.
DepthUncertainty depthUncertainty(const Eigen::Vector3d& bearingRef, double range, const Eigen::Vector3d& t_ref_cur,
                                  double focalLength, double pixelNoise = 1.0);

}  // namespace pslam::landmarks
