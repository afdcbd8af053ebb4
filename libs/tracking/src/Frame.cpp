#include "pslam/tracking/Frame.h"

#include <cmath>
#include <opencv2/imgproc.hpp>

#include "pslam/core/Error.h"

namespace pslam::tracking {

int Frame::numMatchedInliers() const {
  int n = 0;
  for (std::size_t i = 0; i < mapPointIds.size(); ++i)
    if (mapPointIds[i] != map::kNoMapPoint && !outlier[i]) ++n;
  return n;
}

void Frame::resetMatches() {
  mapPointIds.assign(keypoints.size(), map::kNoMapPoint);
  outlier.assign(keypoints.size(), false);
}

Frame makeFrameFromFeatures(std::size_t index, double timestamp, const geometry::PinholeCamera& camera,
                            const std::vector<cv::KeyPoint>& distortedKeypoints, const cv::Mat& descriptors,
                            int numLevels, double scaleFactor, const cv::Mat& semantic) {
  require(descriptors.rows == static_cast<int>(distortedKeypoints.size()), "tracking frame " + std::to_string(index),
          "descriptor rows differ from the number of keypoints");
  Frame f;
  f.index = index;
  f.timestamp = timestamp;
  f.camera = camera.withoutDistortion();
  f.bounds = camera.undistortedBounds();
  f.keypoints = camera.undistortKeyPoints(distortedKeypoints);
  f.descriptors = descriptors;
  f.grid = features::FeatureGrid::fromKeypoints(
      f.keypoints, cv::Rect2f(static_cast<float>(f.bounds.minX), static_cast<float>(f.bounds.minY),
                              static_cast<float>(f.bounds.maxX - f.bounds.minX),
                              static_cast<float>(f.bounds.maxY - f.bounds.minY)));
  for (int l = 0; l < numLevels; ++l) {
    const double s = std::pow(scaleFactor, l);
    f.scaleFactors.push_back(s);
    f.levelSigma2.push_back(s * s);
  }
  if (!semantic.empty()) {
    // The SEMANTIC channel is registered to the raw (distorted) image: sample it where the corner was found.
    f.semanticProbabilities.reserve(distortedKeypoints.size());
    for (const auto& kp : distortedKeypoints) {
      const int x = std::clamp(static_cast<int>(std::lround(kp.pt.x)), 0, semantic.cols - 1);
      const int y = std::clamp(static_cast<int>(std::lround(kp.pt.y)), 0, semantic.rows - 1);
      const cv::Vec3b px = semantic.at<cv::Vec3b>(y, x);
      f.semanticProbabilities.push_back({px[0] / 255.f, px[1] / 255.f, px[2] / 255.f});
    }
  }
  f.resetMatches();
  return f;
}

Frame makeFrame(const datasets::Frame& input, const geometry::PinholeCamera& camera, features::OrbExtractor& extractor,
                const std::string& context, features::OrbStageTimes* times) {
  require(!input.image.empty(), context, "empty image");
  require(input.image.cols == camera.width && input.image.rows == camera.height, context,
          "image size " + std::to_string(input.image.cols) + "x" + std::to_string(input.image.rows) +
              " differs from the camera size " + std::to_string(camera.width) + "x" + std::to_string(camera.height));
  if (input.hasSemantic())
    require(input.semantic.size() == input.image.size() && input.semantic.type() == CV_8UC3, context,
            "SEMANTIC channel must be CV_8UC3 of the image size");
  if (input.hasNormals())
    require(input.normals.size() == input.image.size() && input.normals.type() == CV_8UC3, context,
            "NORMALS channel must be CV_8UC3 of the image size");
  if (input.hasDepth())
    require(input.depth.size() == input.image.size() && input.depth.type() == CV_16UC1 &&
                std::isfinite(input.depthUnits) && input.depthUnits > 0.0,
            context, "DEPTH channel must be CV_16UC1 of the image size with positive depth units");
  cv::Mat grey;
  if (input.image.channels() == 1)
    grey = input.image;
  else if (input.image.channels() == 3)
    cv::cvtColor(input.image, grey, cv::COLOR_BGR2GRAY);
  else if (input.image.channels() == 4)
    cv::cvtColor(input.image, grey, cv::COLOR_BGRA2GRAY);
  else
    throw Error(context + ": unsupported image with " + std::to_string(input.image.channels()) + " channels");
  std::vector<cv::KeyPoint> kps;
  cv::Mat desc;
  extractor.extract(grey, kps, desc, times);
  Frame f = makeFrameFromFeatures(input.index, input.timestamp, camera, kps, desc, extractor.params().nLevels,
                                  extractor.params().scaleFactor, input.semantic);
  // The other channels travel with the frame (shared, not copied) for the front ends that use them: the grey
  // image for direct features (§3.3), NORMALS for the Manhattan frame (§4.4), DEPTH for evaluation.
  f.grey = grey;
  f.semantic = input.semantic;
  f.normals = input.normals;
  f.depth = input.depth;
  f.depthUnits = input.depthUnits;
  return f;
}

}  // namespace pslam::tracking
