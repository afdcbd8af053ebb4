#include "pslam/lines/LineExtractor.h"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <opencv2/imgproc.hpp>
#include <opencv2/line_descriptor.hpp>

#include "pslam/core/Error.h"
#include "pslam/core/PixelCentres.h"

namespace pslam::lines {

PSLAM_DEFINE_PARAMS(LineExtractorParams)

LineExtractor::LineExtractor(const LineExtractorParams& params, const geometry::PinholeCamera& camera)
    : params_(params), camera_(camera) {
  params_.check();
  camera_.check();
}

LineFeatures LineExtractor::extract(const cv::Mat& grey) const {
  require(!grey.empty() && grey.type() == CV_8UC1, "LineExtractor", "needs a non-empty CV_8UC1 image");
  require(grey.cols == camera_.width && grey.rows == camera_.height, "LineExtractor",
          "image " + std::to_string(grey.cols) + "x" + std::to_string(grey.rows) + " differs from the camera " +
              std::to_string(camera_.width) + "x" + std::to_string(camera_.height));
  LineFeatures out;
  out.pixelSigma = pixelSigma();
  out.descriptors = cv::Mat(0, 32, CV_8U);

  // LSD (§2.3.2.2, Algorithm 2) on one level: the image resized by detectionScale.
  const double s = params_.detectionScale;
  cv::Mat level = grey;
  if (s < 1.0)
    cv::resize(grey, level, cv::Size(std::max(1, static_cast<int>(std::lround(grey.cols * s))),
                                     std::max(1, static_cast<int>(std::lround(grey.rows * s)))),
               0, 0, cv::INTER_AREA);
  std::vector<cv::Vec4f> raw;
  cv::createLineSegmentDetector(cv::LSD_REFINE_NONE)->detect(level, raw);
  const double sx = static_cast<double>(grey.cols) / level.cols, sy = static_cast<double>(grey.rows) / level.rows;
  auto toFull = [&](float x, float y) {
    return Eigen::Vector2d(toOriginalPixel(static_cast<double>(x), sx), toOriginalPixel(static_cast<double>(y), sy));
  };
  std::vector<LineSegment> distorted, atLevel;
  for (const cv::Vec4f& l : raw) {
    LineSegment seg{toFull(l[0], l[1]), toFull(l[2], l[3])};
    if (seg.length() >= params_.minLength && seg.length() > 1.0) {
      distorted.push_back(seg);
      atLevel.push_back({Eigen::Vector2d(l[0], l[1]), Eigen::Vector2d(l[2], l[3])});
    }
  }
  // The N longest (ties in detection order: deterministic).
  std::vector<std::size_t> order(distorted.size());
  std::iota(order.begin(), order.end(), std::size_t{0});
  std::stable_sort(order.begin(), order.end(),
                   [&](std::size_t a, std::size_t b) { return distorted[a].length() > distorted[b].length(); });
  if (static_cast<int>(order.size()) > params_.maxLines) order.resize(static_cast<std::size_t>(params_.maxLines));
  if (order.empty()) return out;

  // LBD (eq. 2.56) on the detection level, one octave (a quarter of the full image's cost at scale 0.5);
  // KeyLines filled as LSDDetector fills them.
  std::vector<cv::line_descriptor::KeyLine> keylines;
  keylines.reserve(order.size());
  for (std::size_t k = 0; k < order.size(); ++k) {
    const LineSegment& seg = atLevel[order[k]];
    cv::line_descriptor::KeyLine kl;
    kl.startPointX = static_cast<float>(seg.start.x());
    kl.startPointY = static_cast<float>(seg.start.y());
    kl.endPointX = static_cast<float>(seg.end.x());
    kl.endPointY = static_cast<float>(seg.end.y());
    kl.sPointInOctaveX = kl.startPointX;
    kl.sPointInOctaveY = kl.startPointY;
    kl.ePointInOctaveX = kl.endPointX;
    kl.ePointInOctaveY = kl.endPointY;
    kl.lineLength = static_cast<float>(seg.length());
    kl.angle = static_cast<float>(std::atan2(seg.end.y() - seg.start.y(), seg.end.x() - seg.start.x()));
    kl.octave = 0;
    kl.class_id = static_cast<int>(k);
    kl.pt = cv::Point2f(static_cast<float>(seg.midpoint().x()), static_cast<float>(seg.midpoint().y()));
    kl.response = kl.lineLength / static_cast<float>(std::max(level.cols, level.rows));
    kl.size = std::abs((kl.endPointX - kl.startPointX) * (kl.endPointY - kl.startPointY));
    kl.numOfPixels = static_cast<int>(std::ceil(std::max(std::abs(seg.end.x() - seg.start.x()),
                                                         std::abs(seg.end.y() - seg.start.y()))));
    keylines.push_back(kl);
  }
  cv::line_descriptor::BinaryDescriptor::Params bp;
  bp.numOfOctave_ = 1;
  bp.widthOfBand_ = params_.lbdBandWidth;
  const cv::Ptr<cv::line_descriptor::BinaryDescriptor> lbd = cv::line_descriptor::BinaryDescriptor::createBinaryDescriptor(bp);
  cv::Mat descriptors;
  lbd->compute(level, keylines, descriptors);
  require(descriptors.empty() || (descriptors.type() == CV_8U && descriptors.cols == 32), "LineExtractor",
          "LBD returned descriptors of an unexpected type");

  // Segments in the order of the descriptor rows (class_id names the input segment).
  std::vector<cv::Point2f> ends;
  std::vector<std::size_t> kept;
  for (int r = 0; r < descriptors.rows && r < static_cast<int>(keylines.size()); ++r) {
    const int id = keylines[static_cast<std::size_t>(r)].class_id;
    if (id < 0 || id >= static_cast<int>(order.size())) continue;
    const LineSegment& seg = distorted[order[static_cast<std::size_t>(id)]];
    ends.emplace_back(static_cast<float>(seg.start.x()), static_cast<float>(seg.start.y()));
    ends.emplace_back(static_cast<float>(seg.end.x()), static_cast<float>(seg.end.y()));
    kept.push_back(static_cast<std::size_t>(r));
  }
  const std::vector<cv::Point2f> undistorted = camera_.undistortPoints(ends);
  out.descriptors = cv::Mat(static_cast<int>(kept.size()), 32, CV_8U);
  for (std::size_t k = 0; k < kept.size(); ++k) {
    LineSegment seg{Eigen::Vector2d(undistorted[2 * k].x, undistorted[2 * k].y),
                    Eigen::Vector2d(undistorted[2 * k + 1].x, undistorted[2 * k + 1].y)};
    out.segments.push_back(seg);
    descriptors.row(static_cast<int>(kept[k])).copyTo(out.descriptors.row(static_cast<int>(k)));
  }
  return out;
}

}  // namespace pslam::lines
