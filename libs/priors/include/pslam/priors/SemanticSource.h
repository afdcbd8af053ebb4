#pragma once
// Producers of the SEMANTIC channel for rawlog frames: ground-truth label images mapped through a class map
// (one-hot), or a segmentation network (SemanticNetwork).
#include <filesystem>
#include <memory>
#include <string>

#include <opencv2/core.hpp>

#include "pslam/datasets/Rawlog.h"
#include "pslam/priors/SemanticClassMap.h"
#include "pslam/priors/SemanticNetwork.h"

namespace pslam::priors {

class SemanticSource {
 public:
  virtual ~SemanticSource() = default;
  /// SEMANTIC channel (CV_8UC3, size of frame.image) for one frame. Throws pslam::Error naming the frame.
  virtual cv::Mat compute(const datasets::Frame& frame) = 0;
  virtual std::string description() const = 0;
};

/// Label images `<folder>/<printf(pattern, frame.index)>`, 8-bit class ids (the synthetic generator writes
/// Cityscapes trainIds as `<name>_Labels/LABEL_%06d.png`).
class LabelFolderSource final : public SemanticSource {
 public:
  /// Throws pslam::Error if the folder does not exist or the pattern has no integer conversion.
  LabelFolderSource(std::filesystem::path folder, SemanticClassMap map, std::string pattern = "LABEL_%06d.png");
  cv::Mat compute(const datasets::Frame& frame) override;
  std::string description() const override;
  std::filesystem::path labelPath(std::size_t frameIndex) const;

 private:
  std::filesystem::path folder_;
  SemanticClassMap map_;
  std::string pattern_;
};

class NetworkSource final : public SemanticSource {
 public:
  explicit NetworkSource(const SemanticNetworkParams& params);
  cv::Mat compute(const datasets::Frame& frame) override;
  std::string description() const override;

 private:
  SemanticNetwork network_;
};

}  // namespace pslam::priors
