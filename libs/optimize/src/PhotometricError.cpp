#include "pslam/optimize/PhotometricError.h"

#include <cmath>
#include <limits>

#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Error.h"

namespace pslam::optimize {

double PhotometricParams::whiteningScale() const { return std::sqrt(etaP / etaR); }
double PhotometricParams::whitenedHuberDelta() const { return huberFactor * std::sqrt(etaP) / std::sqrt(etaR); }
double PhotometricParams::whitenedChi2Threshold() const { return chi2PerPixel * kPatternSize * etaP / etaR; }

PSLAM_DEFINE_PARAMS(PhotometricParams)

std::array<Eigen::Vector3d, kPatternSize> patternRays(const DirectLandmark& point, const geometry::PinholeCamera& camera,
                                                     int level) {
  const geometry::PinholeCamera c = levelCamera(camera, level);
  const Eigen::Vector2d p = levelPixel(point.pixel, level);
  std::array<Eigen::Vector3d, kPatternSize> rays;
  for (int k = 0; k < kPatternSize; ++k) {
    const auto& o = kDirectPattern[static_cast<std::size_t>(k)];
    rays[static_cast<std::size_t>(k)] =
        Eigen::Vector3d((p.x() + o[0] - c.cx) / c.fx, (p.y() + o[1] - c.cy) / c.fy, 1.0);
  }
  return rays;
}

DirectLandmark DirectLandmark::create(map::KeyFrameId host, const Eigen::Vector2d& pixel, double inverseDepth,
                                const geometry::PinholeCamera& camera, const ImagePyramid& hostImage) {
  const std::string ctx = "DirectLandmark";
  require(pixel.allFinite() && std::isfinite(inverseDepth) && inverseDepth >= 0.0, ctx,
          "pixel and inverse depth must be finite, inverse depth >= 0");
  require(hostImage.levels() >= 1, ctx, "empty host image");
  DirectLandmark p;
  p.host = host;
  p.pixel = pixel;
  p.bearing = camera.unprojectToBearing(pixel);
  p.inverseDepth = inverseDepth;
  p.hostIntensities.resize(static_cast<std::size_t>(hostImage.levels()));
  for (int l = 0; l < hostImage.levels(); ++l) {
    const cv::Mat& img = hostImage.level(l);
    const Eigen::Vector2d pl = levelPixel(pixel, l);
    std::vector<double> values;
    bool inside = true;
    for (const auto& o : kDirectPattern) inside = inside && insideBilinear(img, pl.x() + o[0], pl.y() + o[1]);
    if (inside)
      for (const auto& o : kDirectPattern) values.push_back(sampleBilinear(img, pl.x() + o[0], pl.y() + o[1]));
    require(inside || l > 0, ctx, "the pattern around the host pixel does not fit into the host image");
    p.hostIntensities[static_cast<std::size_t>(l)] = std::move(values);
  }
  return p;
}

PatternError evaluatePattern(const DirectLandmark& point, int level, const std::array<Eigen::Vector3d, kPatternSize>& rays,
                             const Eigen::Isometry3d& T_target_host, double rho, const geometry::PinholeCamera& camera,
                             const cv::Mat& targetLevel, const AffineBrightness& hostAffine,
                             const AffineBrightness& targetAffine) {
  PatternError pe;
  pe.e.setZero();
  pe.q.fill(Eigen::Vector3d::Zero());
  pe.u.fill(Eigen::Vector2d::Zero());
  pe.gradient.fill(Eigen::Vector2d::Zero());
  if (!point.usableAt(level)) return pe;
  const std::vector<double>& host = point.hostIntensities[static_cast<std::size_t>(level)];
  const geometry::PinholeCamera c = levelCamera(camera, level);
  const double rhoZ = rho / point.bearing.z();
  const double ratio = std::exp(targetAffine.a - hostAffine.a);  // e^{a_j - a_i}
  bool valid = true;
  for (std::size_t k = 0; k < static_cast<std::size_t>(kPatternSize); ++k) {
    const Eigen::Vector3d q = T_target_host.linear() * rays[k] + rhoZ * T_target_host.translation();
    pe.q[k] = q;
    if (!(q.z() > 1e-12)) {
      valid = false;
      continue;
    }
    pe.u[k] = Eigen::Vector2d(c.fx * q.x() / q.z() + c.cx, c.fy * q.y() / q.z() + c.cy);
    valid = valid && insideBilinear(targetLevel, pe.u[k].x(), pe.u[k].y());
    const double I = sampleBilinear(targetLevel, pe.u[k].x(), pe.u[k].y(), &pe.gradient[k]);
    pe.e[static_cast<Eigen::Index>(k)] = I - targetAffine.b - ratio * (host[k] - hostAffine.b);
  }
  pe.valid = valid;
  return pe;
}

double patternSsd(const PatternError& error, const AffineBrightness& targetAffine) {
  if (!error.valid) return std::numeric_limits<double>::infinity();
  return std::exp(-2.0 * targetAffine.a) * error.e.squaredNorm();
}

}  // namespace pslam::optimize
