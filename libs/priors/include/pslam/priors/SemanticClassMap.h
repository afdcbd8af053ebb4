#pragma once
// Mapping from a segmentation label set (a network's output classes or a dataset's label ids) to the three
// classes of the probabilistic model, Table 3.1: static, (potentially) dynamic, invalid. The 19 Cityscapes
// trainId classes are built in; other label sets come from ini files (config/semantic/*.ini):
//
//   [SemanticClassMap]
//   name       = cityscapes
//   numClasses = 19
//   unlabeled  = invalid          ; group of label values >= numClasses in label images (e.g. 255 = ignore)
//   default    = static           ; optional: group of classes without a classN key (else every class needs one)
//   class0     = road static      ; classN = <name> <static|dynamic|invalid>
//   ...
#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "pslam/datasets/Rawlog.h"

namespace mrpt::config {
class CConfigFileBase;
}

namespace pslam::priors {

using datasets::SemanticClass;
inline constexpr int kNumSemanticGroups = 3;

std::string toString(SemanticClass c);

struct SemanticClassMap {
  std::string name;
  std::vector<std::string> classNames;  ///< index = label value / network output channel
  std::vector<SemanticClass> groups;    ///< same size as classNames
  SemanticClass unlabeled = SemanticClass::Invalid;

  /// Table 3.1 for the 19 Cityscapes classes in trainId order (road ... bicycle), 255 -> invalid.
  static SemanticClassMap cityscapes();
  static constexpr const char* kSection = "SemanticClassMap";
  /// Reads an ini file that holds the [SemanticClassMap] section above (and no other). Throws pslam::Error
  /// naming file, section and key.
  static SemanticClassMap loadFromFile(const std::filesystem::path& iniPath);

  /// Strict (pslam/core/Params.h): numClasses in [1, 256], every key one of name, numClasses, unlabeled, default,
  /// class0 ... class<numClasses-1>, groups static | dynamic | invalid; errors are params::ParamError.
  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section);
  /// Non-empty, sizes consistent, at most 256 classes (8-bit label images).
  void check() const;

  int numClasses() const { return static_cast<int>(classNames.size()); }
  /// Group of a label value; values outside [0, numClasses) map to `unlabeled`.
  SemanticClass groupOf(int label) const;
  /// 1x256 CV_8U lookup table label -> group index (for cv::LUT on 8-bit label images).
  cv::Mat groupLookupTable() const;
};

}  // namespace pslam::priors
