#pragma once
// The `framework` key of a network section ([SemanticNetwork], [NormalsFromNetwork]): what cv::dnn::readNet
// accepts (without regard to case), or empty to let it choose from the model's file extension.
#include <algorithm>
#include <cctype>
#include <string>

#include "pslam/core/Params.h"

namespace pslam::priors {

inline bool isDnnFramework(std::string name) {
  std::transform(name.begin(), name.end(), name.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  for (const char* f : {"", "caffe", "tensorflow", "torch", "darknet", "dldt", "onnx"})
    if (name == f) return true;
  return false;
}

inline auto dnnFrameworkRule() {
  return params::satisfies(
      [](const std::string& f) { return isDnnFramework(f); },
      "must be empty (from the model's file extension) or one of caffe, tensorflow, torch, darknet, dldt, onnx");
}

}  // namespace pslam::priors
