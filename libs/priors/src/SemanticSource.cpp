#include "pslam/priors/SemanticSource.h"

#include <cstdio>

#include <opencv2/imgcodecs.hpp>

#include "pslam/core/Error.h"
#include "pslam/priors/SemanticImage.h"

namespace pslam::priors {

LabelFolderSource::LabelFolderSource(std::filesystem::path folder, SemanticClassMap map, std::string pattern)
    : folder_(std::move(folder)), map_(std::move(map)), pattern_(std::move(pattern)) {
  map_.check();
  if (!std::filesystem::is_directory(folder_)) throw Error(folder_.string() + ": label folder not found");
  // Exactly one integer conversion, so that snprintf below is given exactly what it expects.
  const auto pos = pattern_.find('%');
  if (pos == std::string::npos || pattern_.find('%', pos + 1) != std::string::npos ||
      pattern_.find_first_of("diu", pos) == std::string::npos)
    throw Error("label pattern '" + pattern_ + "': needs exactly one integer conversion such as %06d");
}

std::filesystem::path LabelFolderSource::labelPath(std::size_t frameIndex) const {
  char name[512];
  std::snprintf(name, sizeof(name), pattern_.c_str(), static_cast<int>(frameIndex));
  return folder_ / name;
}

cv::Mat LabelFolderSource::compute(const datasets::Frame& frame) {
  const auto path = labelPath(frame.index);
  if (!std::filesystem::is_regular_file(path))
    throw Error(path.string() + ": label image for frame " + std::to_string(frame.index) + " not found");
  const cv::Mat labels = cv::imread(path.string(), cv::IMREAD_UNCHANGED);
  if (labels.empty()) throw Error(path.string() + ": cannot decode label image");
  if (labels.type() != CV_8UC1)
    throw Error(path.string() + ": label image must be 8-bit single channel (class ids), got type " +
                std::to_string(labels.type()));
  if (labels.size() != frame.image.size())
    throw Error(path.string() + ": label image is " + std::to_string(labels.cols) + "x" + std::to_string(labels.rows) +
                ", frame " + std::to_string(frame.index) + " is " + std::to_string(frame.image.cols) + "x" +
                std::to_string(frame.image.rows));
  return semanticFromLabels(labels, map_);
}

std::string LabelFolderSource::description() const {
  return "labels " + (folder_ / pattern_).string() + " (class map " + map_.name + ")";
}

NetworkSource::NetworkSource(const SemanticNetworkParams& params) : network_(params) {}

cv::Mat NetworkSource::compute(const datasets::Frame& frame) {
  try {
    return network_.segment(frame.image);
  } catch (const Error& e) {
    throw Error("frame " + std::to_string(frame.index) + ": " + e.what());
  }
}

std::string NetworkSource::description() const {
  return "network " + network_.params().model.filename().string() + " (class map " + network_.classMap().name + ")";
}

}  // namespace pslam::priors
