#pragma once
// The photometric error of a direct point (thesis §2.3.2.3 eq. 2.64, §3.2.2, joint weighting eq. 3.6 with the
// constants of Table 3.2), shared by PhotometricPoseFactor (tracking) and PhotometricBAFactor (local BA).
//
// A direct point lives in its host keyframe i: the host pixel p (level 0, undistorted), its unit bearing b and
// the inverse depth rho along that bearing, P_i = b / rho -- the parameterization of the ORB map points (eq. 3.1,
// BAPoint), except that eq. 3.1 takes the inverse depth along the z-axis: rho_z = rho / b_z.
// Around p it carries N_P = 9 pattern pixels (Table 3.2): DSO's residual pattern (Engel et al., DSO, Fig. 4;
// settings.cpp staticPattern[8], its default) has 8 of them -- the caption says the bottom-right pixel is
// omitted only for SSE-optimized processing -- so we use it with (+1,+1) restored, which is DSO's
// staticPattern[4] "full-spread-9":
//     (0,-2) (-1,-1) (+1,-1) (-2,0) (0,0) (+2,0) (-1,+1) (+1,+1) (0,+2)      (dx, dy) in level pixels.
// (DirectLandmark is the map-side point; pslam::features::DirectPoint is the selector's pixel candidate.)
// As in DSO, every pattern pixel is a point of the fronto-parallel plane through P_i: pattern pixel k of level
// l is X_k = z_i m_k with m_k = K_l^-1 (p_l + o_k, 1) and z_i = b_z / rho. Its homogeneous position in target j,
//     q_k = rho_z X_j,k = R_ji m_k + rho_z t_ji,        u_k = pi_l(q_k)            (T_ji = T_j_world T_i_world^-1)
// stays finite for rho -> 0 (a point at infinity still constrains the rotation).
//
// Exposure (DSO's affine model, Engel et al. eq. 4, exposure times folded into a): image k sees the scene
// radiance L as I_k = e^{a_k} L + b_k, hence
//     e_k = I_j(u_k) - b_j - e^{a_j - a_i} (I_i(p_l + o_k) - b_i)                                   (residual)
// with bilinear interpolation of both images (eq. 2.64), intensities in [0, 1]. Our a is -alpha of eq. 2.62
// (Phi = e^alpha (I - beta) / t, t = 1): e^{a_j - a_i} is DSO's ratio e^{a_j} t_j / (e^{a_i} t_i).
//
// Weighting (eq. 3.6, Table 3.2): E = eta_R sum E_R^T S_R^-1 E_R + eta_P sum E_P^T S_P^-1 E_P with S_P = I.
// The optimizers of this library whiten keypoints without eta_R (ReprojectionError.h), i.e. they minimize
// E / eta_R, so a direct point enters with the whitened residual r = sqrt(eta_P / eta_R) e (9 rows), and
//   - Huber threshold delta_P = 0.4 sqrt(eta_P) on sqrt(eta_P) |e| (Table 3.2)  ->  delta_P / sqrt(eta_R) on |r|;
//   - outlier threshold chi2_P = 0.05 N_P on e^T S_P^-1 e = |e|^2 (Table 3.2, tested like chi_R, on the error
//     without the eta weight)                                                   ->  chi2_P eta_P / eta_R on |r|^2.
// Both thresholds keep their meaning in intensities: Huber beyond |e| = 0.4, outlier beyond |e|^2 = 0.45 (an
// RMS difference of 0.22 = 57 grey levels over the 9 pixels).
#include <array>
#include <memory>
#include <string>
#include <vector>

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "pslam/core/Params.h"
#include "pslam/map/Types.h"
#include "pslam/optimize/ImagePyramid.h"

namespace pslam::optimize {

inline constexpr int kPatternSize = 9;  ///< N_P^Direct (Table 3.2)
/// The pattern offsets (dx, dy) in pixels of the level evaluated (see the header comment).
inline constexpr std::array<std::array<int, 2>, kPatternSize> kDirectPattern{
    {{0, -2}, {-1, -1}, {1, -1}, {-2, 0}, {0, 0}, {2, 0}, {-1, 1}, {1, 1}, {0, 2}}};
inline constexpr int kPatternPadding = 2;  ///< largest |offset| of the pattern

/// The constants of the photometric term in the units of the thesis (Table 3.2, eq. 3.6).
struct PhotometricParams {
  double etaR = 0.5;                    ///< eta_R: weight of the keypoint re-projection term (Table 3.2)
  double etaP = 0.5 / kPatternSize;     ///< eta_P = 0.5 / N_P: weight of the photometric term (Table 3.2)
  double huberFactor = 0.4;             ///< delta_P = huberFactor * sqrt(eta_P) (Table 3.2)
  double chi2PerPixel = 0.05;           ///< chi2_P = chi2PerPixel * N_P (Table 3.2)

  /// sqrt(eta_P / eta_R): whitened residual per unit intensity difference.
  double whiteningScale() const;
  /// delta_P = 0.4 sqrt(eta_P) in whitened units (/ sqrt(eta_R)).
  double whitenedHuberDelta() const;
  /// chi2_P = 0.05 N_P in whitened units (* eta_P / eta_R).
  double whitenedChi2Threshold() const;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, etaR, greaterThan(0), "eta_R: weight of the keypoint re-projection term (Table 3.2)");
    PSLAM_FIELD(v, etaP, greaterThan(0), "eta_P = 0.5 / N_P: weight of the photometric term (Table 3.2)");
    PSLAM_FIELD(v, huberFactor, greaterThan(0), "delta_P = huberFactor * sqrt(eta_P) (Table 3.2)");
    PSLAM_FIELD(v, chi2PerPixel, greaterThan(0), "chi2_P = chi2PerPixel * N_P (Table 3.2)");
  }
  /// loadFromConfigFile / saveToConfigFile; check() throws params::ParamError naming the offending key.
  PSLAM_PARAMS("Photometric")
};

/// Affine brightness of one image: I = e^a L + b for the scene radiance L (DSO; see the header comment).
struct AffineBrightness {
  double a = 0.0;
  double b = 0.0;
};

/// A direct point in its host keyframe (fixed data of the factors; the inverse depth is also the BA block).
struct DirectLandmark {
  map::KeyFrameId host = map::kNoKeyFrame;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();       ///< host pixel, level 0, undistorted
  Eigen::Vector3d bearing = Eigen::Vector3d::UnitZ();    ///< unit bearing of `pixel` in the host camera
  double inverseDepth = 1.0;                             ///< rho = 1 / |P_i| along the bearing
  bool fixed = false;                                    ///< inverse depth held constant in BA
  /// Per pyramid level: the host intensities of the pattern (bilinear, [0, 1]); empty when the pattern does not
  /// fit into that level of the host image (the point is then not used at that level).
  std::vector<std::vector<double>> hostIntensities;

  /// The point at level 0 of a camera: bearing from `pixel`, host intensities sampled from `hostImage` on all
  /// its levels. Throws pslam::Error when the pattern does not fit into level 0, for rho < 0 or non-finite input.
  static DirectLandmark create(map::KeyFrameId host, const Eigen::Vector2d& pixel, double inverseDepth,
                            const geometry::PinholeCamera& camera, const ImagePyramid& hostImage);
  int levels() const { return static_cast<int>(hostIntensities.size()); }
  bool usableAt(int level) const {
    return level >= 0 && level < levels() && !hostIntensities[static_cast<std::size_t>(level)].empty();
  }
};

/// The unnormalized photometric error of one direct point at one pyramid level: per pattern pixel k the
/// homogeneous target point q_k, the target pixel u_k, the intensity gradient g_k at u_k and the error e_k.
struct PatternError {
  std::array<Eigen::Vector3d, kPatternSize> q;
  std::array<Eigen::Vector2d, kPatternSize> u;
  std::array<Eigen::Vector2d, kPatternSize> gradient;
  Eigen::Matrix<double, kPatternSize, 1> e;
  bool valid = false;  ///< every q_k in front of the target and every u_k inside the target image
};

/// Normalized host coordinates m_k of the pattern at `level` (camera = level-0 intrinsics).
std::array<Eigen::Vector3d, kPatternSize> patternRays(const DirectLandmark& point, const geometry::PinholeCamera& camera,
                                                     int level);

/// e_k of the header comment for the relative pose T_target_host, inverse depth `rho`, target image level
/// `targetLevel` of `level`. Out-of-image samples are clamped to the border (e stays finite, valid = false).
PatternError evaluatePattern(const DirectLandmark& point, int level, const std::array<Eigen::Vector3d, kPatternSize>& rays,
                             const Eigen::Isometry3d& T_target_host, double rho, const geometry::PinholeCamera& camera,
                             const cv::Mat& targetLevel, const AffineBrightness& hostAffine,
                             const AffineBrightness& targetAffine);

/// Sum of squared exposure-normalized differences of eq. 3.5 over the pattern, each image mapped to the radiance
/// e^{-a}(I - b) (DSO's sign): the Delta Phi of the matching accuracy alpha_dir (eq. 3.4). It equals
/// e^{-2 a_j} |e|^2; infinity when the pattern is not valid in the target.
double patternSsd(const PatternError& error, const AffineBrightness& targetAffine);

}  // namespace pslam::optimize
