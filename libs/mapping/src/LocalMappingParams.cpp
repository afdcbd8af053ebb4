#include <cmath>

#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Error.h"
#include "pslam/mapping/LocalMapper.h"

namespace pslam::mapping {

void LocalMappingParams::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& s) {
  covisibleKeyFrames = cfg.read_int(s, "covisibleKeyframes", covisibleKeyFrames);
  maxDescriptorDistance = cfg.read_int(s, "maxDescriptorDistance", maxDescriptorDistance);
  nnRatio = cfg.read_double(s, "nnRatio", nnRatio);
  checkOrientation = cfg.read_bool(s, "checkOrientation", checkOrientation);
  minBaselineRatio = cfg.read_double(s, "minBaselineRatio", minBaselineRatio);
  maxParallaxCos = cfg.read_double(s, "maxParallaxCos", maxParallaxCos);
  chi2Threshold = cfg.read_double(s, "chi2Threshold", chi2Threshold);
  scaleConsistencyFactor = cfg.read_double(s, "scaleConsistencyFactor", scaleConsistencyFactor);
  epipolarMinDistancePixels = cfg.read_double(s, "epipolarMinDistance", epipolarMinDistancePixels);
  fusionNeighbours = cfg.read_int(s, "fusionNeighbours", fusionNeighbours);
  fusionSecondOrderNeighbours = cfg.read_int(s, "fusionSecondOrderNeighbours", fusionSecondOrderNeighbours);
  fusionRadiusPixels = cfg.read_double(s, "fusionRadius", fusionRadiusPixels);
  fusionDistanceBand = cfg.read_double(s, "fusionDistanceBand", fusionDistanceBand);
  // The map-point model defaults to ORB-SLAM* (heuristic) unless the section names one.
  pointPolicy.loadFromConfigFile(cfg, s);
  keypointModel.loadFromConfigFile(cfg, s);
  matchingAccuracy.loadFromConfigFile(cfg, s);
  depthPixelNoise = cfg.read_double(s, "depthPixelNoise", depthPixelNoise);
  cullKeyFrames = cfg.read_bool(s, "cullKeyFrames", cullKeyFrames);
  redundantFraction = cfg.read_double(s, "redundantFraction", redundantFraction);
  redundantMinObservers = cfg.read_int(s, "redundantMinObservers", redundantMinObservers);
  localBundleAdjustment = cfg.read_bool(s, "localBundleAdjustment", localBundleAdjustment);
}

void LocalMappingParams::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& s) const {
  cfg.write(s, "covisibleKeyframes", covisibleKeyFrames);
  cfg.write(s, "maxDescriptorDistance", maxDescriptorDistance);
  cfg.write(s, "nnRatio", nnRatio);
  cfg.write(s, "checkOrientation", checkOrientation);
  cfg.write(s, "minBaselineRatio", minBaselineRatio);
  cfg.write(s, "maxParallaxCos", maxParallaxCos);
  cfg.write(s, "chi2Threshold", chi2Threshold);
  cfg.write(s, "scaleConsistencyFactor", scaleConsistencyFactor);
  cfg.write(s, "epipolarMinDistance", epipolarMinDistancePixels);
  cfg.write(s, "fusionNeighbours", fusionNeighbours);
  cfg.write(s, "fusionSecondOrderNeighbours", fusionSecondOrderNeighbours);
  cfg.write(s, "fusionRadius", fusionRadiusPixels);
  cfg.write(s, "fusionDistanceBand", fusionDistanceBand);
  pointPolicy.saveToConfigFile(cfg, s);
  keypointModel.saveToConfigFile(cfg, s);
  matchingAccuracy.saveToConfigFile(cfg, s);
  cfg.write(s, "depthPixelNoise", depthPixelNoise);
  cfg.write(s, "cullKeyFrames", cullKeyFrames);
  cfg.write(s, "redundantFraction", redundantFraction);
  cfg.write(s, "redundantMinObservers", redundantMinObservers);
  cfg.write(s, "localBundleAdjustment", localBundleAdjustment);
}

void LocalMappingParams::check() const {
  const std::string c = "[LocalMapping] ";
  require(covisibleKeyFrames >= 1, c + "covisibleKeyframes", "must be >= 1");
  require(maxDescriptorDistance >= 0 && maxDescriptorDistance <= 256, c + "maxDescriptorDistance",
          "must be in [0, 256]");
  require(nnRatio > 0.0 && nnRatio <= 1.0, c + "nnRatio", "must be in (0, 1]");
  require(std::isfinite(minBaselineRatio) && minBaselineRatio >= 0.0, c + "minBaselineRatio", "must be >= 0");
  require(maxParallaxCos > 0.0 && maxParallaxCos < 1.0, c + "maxParallaxCos", "must be in (0, 1)");
  require(std::isfinite(chi2Threshold) && chi2Threshold > 0.0, c + "chi2Threshold", "must be > 0");
  require(std::isfinite(scaleConsistencyFactor) && scaleConsistencyFactor >= 1.0, c + "scaleConsistencyFactor",
          "must be >= 1");
  require(std::isfinite(epipolarMinDistancePixels) && epipolarMinDistancePixels >= 0.0, c + "epipolarMinDistance",
          "must be >= 0");
  require(fusionNeighbours >= 0, c + "fusionNeighbours", "must be >= 0");
  require(fusionSecondOrderNeighbours >= 0, c + "fusionSecondOrderNeighbours", "must be >= 0");
  require(std::isfinite(fusionRadiusPixels) && fusionRadiusPixels > 0.0, c + "fusionRadius", "must be > 0");
  require(std::isfinite(fusionDistanceBand) && fusionDistanceBand >= 0.0 && fusionDistanceBand < 1.0,
          c + "fusionDistanceBand", "must be in [0, 1)");
  require(std::isfinite(depthPixelNoise) && depthPixelNoise > 0.0, c + "depthPixelNoise", "must be > 0");
  require(redundantFraction > 0.0 && redundantFraction <= 1.0, c + "redundantFraction", "must be in (0, 1]");
  require(redundantMinObservers >= 1, c + "redundantMinObservers", "must be >= 1");
  pointPolicy.check();
  keypointModel.check();
  matchingAccuracy.check();
  ba.check();
}

}  // namespace pslam::mapping
