#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Error.h"
#include "pslam/features/OrbExtractor.h"

namespace pslam::features {

void OrbParams::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section) {
  nFeatures = cfg.read_int(section, "nFeatures", nFeatures);
  scaleFactor = cfg.read_double(section, "scaleFactor", scaleFactor);
  nLevels = cfg.read_int(section, "nLevels", nLevels);
  iniThFAST = cfg.read_int(section, "iniThFAST", iniThFAST);
  minThFAST = cfg.read_int(section, "minThFAST", minThFAST);
  edgeThreshold = cfg.read_int(section, "edgeThreshold", edgeThreshold);
  patchSize = cfg.read_int(section, "patchSize", patchSize);
  cellSize = cfg.read_int(section, "cellSize", cellSize);
  levelBudgetByArea = cfg.read_bool(section, "levelBudgetByArea", levelBudgetByArea);
  literalCellFast = cfg.read_bool(section, "literalCellFast", literalCellFast);
  check();
}

void OrbParams::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const {
  cfg.write(section, "nFeatures", nFeatures);
  cfg.write(section, "scaleFactor", scaleFactor);
  cfg.write(section, "nLevels", nLevels);
  cfg.write(section, "iniThFAST", iniThFAST);
  cfg.write(section, "minThFAST", minThFAST);
  cfg.write(section, "edgeThreshold", edgeThreshold);
  cfg.write(section, "patchSize", patchSize);
  cfg.write(section, "cellSize", cellSize);
  cfg.write(section, "levelBudgetByArea", levelBudgetByArea);
  cfg.write(section, "literalCellFast", literalCellFast);
}

void OrbParams::check() const {
  const std::string ctx = "OrbParams";
  require(nFeatures > 0, ctx, "nFeatures must be > 0 (got " + std::to_string(nFeatures) + ")");
  require(scaleFactor > 1.0 && scaleFactor < 4.0, ctx,
          "scaleFactor must be in (1, 4) (got " + std::to_string(scaleFactor) + ")");
  require(nLevels >= 1 && nLevels <= 32, ctx, "nLevels must be in [1, 32] (got " + std::to_string(nLevels) + ")");
  require(iniThFAST > 0 && iniThFAST < 255, ctx, "iniThFAST must be in (0, 255) (got " + std::to_string(iniThFAST) + ")");
  require(minThFAST > 0 && minThFAST <= iniThFAST, ctx,
          "minThFAST must be in (0, iniThFAST] (got " + std::to_string(minThFAST) + ")");
  // The learned rBRIEF test pattern is defined on a 31x31 patch; other sizes would silently rescale it.
  require(patchSize == 31, ctx, "patchSize must be 31, the size of the learned rBRIEF pattern (got " +
                                    std::to_string(patchSize) + ")");
  // Keypoints keep edgeThreshold-3 px from the level edge and the padding is edgeThreshold px: the circular
  // orientation patch (radius 15) must fit inside the level and the rotated BRIEF tests (reach <= 19 px incl.
  // the 7x7 blur) inside level + padding.
  require(edgeThreshold >= patchSize / 2 + 4, ctx,
          "edgeThreshold must be >= " + std::to_string(patchSize / 2 + 4) + " (got " + std::to_string(edgeThreshold) + ")");
  require(cellSize >= 8, ctx, "cellSize must be >= 8 (got " + std::to_string(cellSize) + ")");
}

}  // namespace pslam::features
