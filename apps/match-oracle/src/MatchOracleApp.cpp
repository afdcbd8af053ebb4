#include "pslam/features/MatchOracleApp.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <deque>
#include <numeric>
#include <optional>

#include <Eigen/Geometry>
#include <opencv2/imgproc.hpp>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/core/Params.h"
#include "pslam/core/Progress.h"
#include "pslam/core/StageTimer.h"
#include "pslam/core/Trajectory.h"
#include "pslam/datasets/Rawlog.h"
#include "pslam/eval/Metrics.h"
#include "pslam/eval/Plot.h"
#include "pslam/features/Matching.h"
#include "pslam/features/OrbExtractor.h"
#include "pslam/features/PatchAlignment.h"
#include "pslam/features/PatchAlignment.h"
#include "pslam/system/SlamParams.h"

namespace fs = std::filesystem;

namespace pslam::features {

namespace {

/// One frame as the oracle needs it: keypoints, descriptors, depth in metres per keypoint, pose.
struct OracleFrame {
  std::size_t index = 0;
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  std::vector<double> keypointDepth;  ///< [m], 0 = none
  cv::Mat depth;                      ///< CV_16UC1
  double depthUnits = 0;
  Eigen::Isometry3d T_world_cam = Eigen::Isometry3d::Identity();
  std::shared_ptr<const ScalePyramid> pyramid;  ///< with --align
};

double depthAt(const cv::Mat& depth, double units, double u, double v) {
  const int x = static_cast<int>(std::lround(u)), y = static_cast<int>(std::lround(v));
  if (x < 0 || y < 0 || x >= depth.cols || y >= depth.rows) return 0;
  return depth.at<uint16_t>(y, x) * units;
}

PairCounts countPair(const OracleFrame& a, const OracleFrame& b, const mrpt::img::TCamera& cam,
                     const std::vector<float>& scales, const MatchOracleOptions& o,
                     std::vector<LevelOffsets>& offsets, const PatchAlignmentParams& alignment) {
  PairCounts c;
  c.first = a.index;
  c.second = b.index;
  const Eigen::Isometry3d T_b_a = b.T_world_cam.inverse() * a.T_world_cam;
  c.baseline = T_b_a.translation().norm();
  c.rotationDeg = Eigen::AngleAxisd(T_b_a.linear()).angle() * 180.0 / M_PI;
  c.keypoints = a.keypoints.size();
  const double fx = cam.fx(), fy = cam.fy(), cx = cam.cx(), cy = cam.cy();
  const int cols = static_cast<int>(cam.ncols), rows = static_cast<int>(cam.nrows);
  std::vector<std::size_t> all(b.keypoints.size());
  std::iota(all.begin(), all.end(), std::size_t{0});
  for (std::size_t i = 0; i < a.keypoints.size(); ++i) {
    const double d = a.keypointDepth[i];
    if (d <= 0) continue;
    ++c.withDepth;
    const cv::Point2f& p = a.keypoints[i].pt;
    const Eigen::Vector3d Xa((p.x - cx) / fx * d, (p.y - cy) / fy * d, d);
    const Eigen::Vector3d Xb = T_b_a * Xa;
    if (Xb.z() <= 0) continue;
    const double u = fx * Xb.x() / Xb.z() + cx, v = fy * Xb.y() / Xb.z() + cy;
    if (u < 0 || v < 0 || u > cols - 1 || v > rows - 1) continue;
    // Occluded when the second frame sees a surface clearly in front of the point (no depth there: kept).
    const double db = depthAt(b.depth, b.depthUnits, u, v);
    if (db > 0 && Xb.z() > db * (1.0 + o.depthTolerance)) continue;
    ++c.visible;
    const double r = o.radius * scales[static_cast<std::size_t>(a.keypoints[i].octave)];
    std::vector<std::size_t> inRadius;
    for (std::size_t j = 0; j < b.keypoints.size(); ++j) {
      const double du = b.keypoints[j].pt.x - u, dv = b.keypoints[j].pt.y - v;
      if (du * du + dv * dv <= r * r) inRadius.push_back(j);
    }
    if (inRadius.empty()) continue;
    ++c.repeated;
    const uint8_t* descriptor = a.descriptors.ptr<uint8_t>(static_cast<int>(i));
    const BestCandidate inside = bestCandidate(descriptor, b.descriptors, inRadius);
    if (inside.distance > o.maxHamming) continue;
    ++c.matchable;
    const std::size_t level = static_cast<std::size_t>(a.keypoints[i].octave);
    const cv::Point2f& q = b.keypoints[static_cast<std::size_t>(inside.index)].pt;
    offsets[level].dx.push_back(static_cast<float>((q.x - u) / scales[level]));
    offsets[level].dy.push_back(static_cast<float>((q.y - v) / scales[level]));
    if (o.align) {
      // The second keypoint aligned to the first one's patch, with the warp the true geometry predicts for a
      // fronto-parallel patch at the first keypoint's depth (features::alignPatch with its default parameters).
      const cv::KeyPoint& kb = b.keypoints[static_cast<std::size_t>(inside.index)];
      const int la = a.keypoints[i].octave, lb = kb.octave;
      const Eigen::Vector2d ca = a.pyramid->toLevel(Eigen::Vector2d(p.x, p.y), la);
      const auto transfer = [&](const Eigen::Vector2d& levelPixel) -> std::optional<Eigen::Vector2d> {
        const Eigen::Vector2d x = a.pyramid->toLevel0(levelPixel, la);
        const Eigen::Vector3d Pb = T_b_a * Eigen::Vector3d((x.x() - cx) / fx * d, (x.y() - cy) / fy * d, d);
        if (!(Pb.z() > 0)) return std::nullopt;
        return b.pyramid->toLevel(Eigen::Vector2d(fx * Pb.x() / Pb.z() + cx, fy * Pb.y() / Pb.z() + cy), lb);
      };
      const std::optional<PatchWarp> warp = patchWarpOf(transfer, ca, alignment.halfPatch);
      const Eigen::Vector2d start = b.pyramid->toLevel(Eigen::Vector2d(kb.pt.x, kb.pt.y), lb);
      ++offsets[level].alignTried;
      const PatchAlignmentResult r =
          warp ? alignPatch(a.pyramid->level(la), ca, warp->A, b.pyramid->level(lb), start, alignment)
               : PatchAlignmentResult{};
      if (r.accepted) {
        const Eigen::Vector2d e = b.pyramid->toLevel0(r.position, lb) - Eigen::Vector2d(u, v);
        offsets[level].alignedDx.push_back(static_cast<float>(e.x() / scales[level]));
        offsets[level].alignedDy.push_back(static_cast<float>(e.y() / scales[level]));
      }
    }
    // What a search without any pose prediction finds: the nearest descriptor over the whole image, kept when
    // it passes the threshold and the ratio test; correct when it lies within the radius.
    const BestCandidate nn = bestCandidate(descriptor, b.descriptors, all);
    if (nn.accepted(o.maxHamming, static_cast<float>(o.ratio)) &&
        std::binary_search(inRadius.begin(), inRadius.end(), static_cast<std::size_t>(nn.index)))
      ++c.foundByDescriptor;
  }
  return c;
}

nlohmann::json toJson(const PairCounts& c) {
  return {{"first", c.first},         {"second", c.second},       {"step", c.step},
          {"baseline_m", c.baseline}, {"rotation_deg", c.rotationDeg}, {"keypoints", c.keypoints},
          {"with_depth", c.withDepth}, {"visible", c.visible},    {"repeated", c.repeated},
          {"matchable", c.matchable}, {"found_by_descriptor", c.foundByDescriptor}};
}

}  // namespace

void MatchOracleOptions::check() const {
  params::checkOption("--steps", steps, params::inClosed(1, 1000));
  params::checkOption("--radius", radius, params::inOpen(0, 1000));
  params::checkOption("--max-hamming", maxHamming, params::inClosed(0, 256));
  params::checkOption("--ratio", ratio, params::inOpen(0, 1.0000001));
  params::checkOption("--depth-tolerance", depthTolerance, params::atLeast(0));
  params::checkOption("--max-gt-dt", maxGroundTruthDt, params::atLeast(0));
  params::checkOption("--min-matches", minMatches, params::atLeast(0));
  require(!rawlog.empty(), "match-oracle", "an input rawlog is required");
  require(!config.empty(), "--config", "a SLAM ini is required (its [ORB] section sets the extractor)");
}

MatchOracleResult runMatchOracle(const MatchOracleOptions& o) {
  o.check();
  require(fs::is_regular_file(o.rawlog), o.rawlog.string(), "rawlog not found");
  require(fs::is_regular_file(o.config), o.config.string(), "config not found");
  const system::SlamParams slam = system::loadSlamParams(o.config.string(), o.overrides);
  fs::path gtPath = o.groundTruth;
  if (gtPath.empty()) gtPath = o.rawlog.parent_path() / (o.rawlog.stem().string() + "_groundtruth.txt");
  require(fs::is_regular_file(gtPath), gtPath.string(), "ground-truth file not found");
  std::vector<fs::path> inputs = datasets::RawlogWriter::inputFilesOf(o.rawlog);
  inputs.push_back(gtPath);
  inputs.push_back(o.config);
  OutputSet outputs(inputs);
  AtomicOutput* jsonOut = o.outputJson.empty() ? nullptr : &outputs.add(o.outputJson);
  AtomicOutput* plotOut = o.outputPlot.empty() ? nullptr : &outputs.add(o.outputPlot);
  Trajectory gt = readTumTrajectory(gtPath);
  std::sort(gt.begin(), gt.end(), [](const StampedPose& a, const StampedPose& b) { return a.timestamp < b.timestamp; });

  datasets::RawlogChannels channels;
  channels.semantic = false;
  channels.normals = false;
  datasets::RawlogReader reader(o.rawlog, channels);
  Progress progress("match-oracle", datasets::RawlogReader::countFrames(o.rawlog), o.progress);
  OrbExtractor extractor(slam.orb);
  MatchOracleResult result;
  result.offsets.resize(extractor.scaleFactors().size());
  for (std::size_t l = 0; l < result.offsets.size(); ++l) result.offsets[l].level = static_cast<int>(l);
  std::deque<OracleFrame> window;  // the last `steps` frames
  mrpt::img::TCamera camera;
  datasets::Frame frame;
  std::size_t nFrames = 0;
  while (reader.next(frame)) {
    const std::string where = o.rawlog.string() + " frame " + std::to_string(frame.index);
    require(frame.hasDepth(), where, "no DEPTH channel (the oracle needs depth to move keypoints between frames)");
    for (std::size_t k = 0; k < frame.camera.dist.size(); ++k)
      require(frame.camera.dist[k] == 0.0, where, "lens distortion is not supported (pinhole projection only)");
    camera = frame.camera;
    const StampedPose* pose = nearestPose(gt, frame.timestamp, o.maxGroundTruthDt);
    require(pose != nullptr, where,
            "no ground-truth pose within " + std::to_string(o.maxGroundTruthDt) + " s in " + gtPath.string());
    OracleFrame f;
    f.index = frame.index;
    f.T_world_cam = pose->T_world_cam();
    f.depth = frame.depth;
    f.depthUnits = frame.depthUnits;
    cv::Mat grey = frame.image;
    if (grey.channels() == 3) cv::cvtColor(frame.image, grey, cv::COLOR_BGR2GRAY);
    extractor.extract(grey, f.keypoints, f.descriptors);
    if (o.align) {
      const std::vector<float>& s = extractor.scaleFactors();
      f.pyramid = std::make_shared<const ScalePyramid>(grey, std::vector<double>(s.begin(), s.end()));
    }
    f.keypointDepth.reserve(f.keypoints.size());
    for (const cv::KeyPoint& kp : f.keypoints)
      f.keypointDepth.push_back(depthAt(f.depth, f.depthUnits, kp.pt.x, kp.pt.y));
    for (std::size_t back = 0; back < window.size(); ++back) {
      const OracleFrame& first = window[window.size() - 1 - back];
      PairCounts c = countPair(first, f, camera, extractor.scaleFactors(), o, result.offsets,
                               features::PatchAlignmentParams{});
      c.step = static_cast<int>(back) + 1;
      result.pairs.push_back(c);
    }
    window.push_back(std::move(f));
    if (static_cast<int>(window.size()) > o.steps) window.pop_front();
    progress.update(++nFrames);
  }
  require(nFrames >= 2, o.rawlog.string(), "fewer than two frames");
  progress.finish(std::to_string(result.pairs.size()) + " pairs");

  // Summary per step: medians and the share of pairs with at least minMatches matchable / found.
  nlohmann::json perStep = nlohmann::json::array();
  char line[256];
  std::snprintf(line, sizeof line, ", %zu frames, [ORB] nFeatures %d, radius %.1f px, max Hamming %d\n", nFrames,
                slam.orb.nFeatures, o.radius, o.maxHamming);
  std::string text = "match-oracle: " + o.rawlog.string() + line;
  std::snprintf(line, sizeof line, "%4s %5s %9s %8s %9s %8s %8s %9s %9s %9s %8s\n", "step", "pairs", "baseline",
                "rot_deg", "keypoints", "w_depth", "visible", "repeated", "matchable", "found_nn", "pairs>=");
  text += line;
  for (int s = 1; s <= o.steps; ++s) {
    std::vector<double> base, rot, kp, wd, vis, rep, mat, nn;
    std::size_t enoughMatchable = 0, enoughFound = 0;
    for (const PairCounts& c : result.pairs) {
      if (c.step != s) continue;
      base.push_back(c.baseline);
      rot.push_back(c.rotationDeg);
      kp.push_back(static_cast<double>(c.keypoints));
      wd.push_back(static_cast<double>(c.withDepth));
      vis.push_back(static_cast<double>(c.visible));
      rep.push_back(static_cast<double>(c.repeated));
      mat.push_back(static_cast<double>(c.matchable));
      nn.push_back(static_cast<double>(c.foundByDescriptor));
      enoughMatchable += c.matchable >= static_cast<std::size_t>(o.minMatches);
      enoughFound += c.foundByDescriptor >= static_cast<std::size_t>(o.minMatches);
    }
    if (base.empty()) continue;
    const auto med = [](const std::vector<double>& v) { return percentile(v, 50.0); };
    perStep.push_back({{"step", s},
                       {"pairs", base.size()},
                       {"median_baseline_m", med(base)},
                       {"median_rotation_deg", med(rot)},
                       {"median_keypoints", med(kp)},
                       {"median_with_depth", med(wd)},
                       {"median_visible", med(vis)},
                       {"median_repeated", med(rep)},
                       {"median_matchable", med(mat)},
                       {"p10_matchable", percentile(mat, 10.0)},
                       {"median_found_by_descriptor", med(nn)},
                       {"pairs_with_min_matchable", enoughMatchable},
                       {"pairs_with_min_found", enoughFound}});
    std::snprintf(line, sizeof line, "%4d %5zu %9.3f %8.1f %9.0f %8.0f %8.0f %9.0f %9.0f %9.0f %3zu/%-3zu\n", s,
                  base.size(), med(base), med(rot), med(kp), med(wd), med(vis), med(rep), med(mat), med(nn),
                  enoughMatchable, base.size());
    text += line;
  }
  text += "(medians over the pairs; pairs>=: pairs with at least " + std::to_string(o.minMatches) +
          " matchable correspondences)\n";

  // Where the matchable correspondences land, per pyramid level (LevelOffsets); with --align also the aligned ones.
  struct OffsetSummary {
    double meanX = 0, meanY = 0, rms = 0, median = 0, p90 = 0;
  };
  const auto summarize = [](const std::vector<float>& dx, const std::vector<float>& dy) {
    std::vector<double> norms;
    norms.reserve(dx.size());
    for (std::size_t i = 0; i < dx.size(); ++i) norms.push_back(std::hypot(double(dx[i]), double(dy[i])));
    const double n = static_cast<double>(dx.size());
    // The RMS of the offset vectors is that of their norms.
    const eval::ErrorStatistics stats = eval::computeStatistics(norms, "keypoint offsets");
    return OffsetSummary{std::accumulate(dx.begin(), dx.end(), 0.0) / n, std::accumulate(dy.begin(), dy.end(), 0.0) / n,
                         stats.rmse, stats.median, percentile(norms, 90.0)};
  };
  nlohmann::json perLevel = nlohmann::json::array();
  text += "matchable correspondences: second keypoint - first moved by the true poses, in level pixels\n";
  std::snprintf(line, sizeof line, "%5s %8s %8s %8s %8s %10s %9s\n", "level", "n", "mean_x", "mean_y", "rms",
                "median|e|", "p90|e|");
  text += line;
  for (const LevelOffsets& l : result.offsets) {
    if (l.dx.empty()) continue;
    const OffsetSummary d = summarize(l.dx, l.dy);
    perLevel.push_back({{"level", l.level},
                        {"correspondences", l.dx.size()},
                        {"mean_x_level_px", d.meanX},
                        {"mean_y_level_px", d.meanY},
                        {"rms_level_px", d.rms},
                        {"median_norm_level_px", d.median},
                        {"p90_norm_level_px", d.p90}});
    std::snprintf(line, sizeof line, "%5d %8zu %+8.3f %+8.3f %8.3f %10.3f %9.3f\n", l.level, l.dx.size(), d.meanX,
                  d.meanY, d.rms, d.median, d.p90);
    text += line;
  }
  if (o.align) {
    text += "aligned to the first keypoint's patch (features::alignPatch): accepted second keypoints, same "
            "transfer\n";
    std::snprintf(line, sizeof line, "%5s %8s %9s %8s %8s %8s %10s %9s\n", "level", "tried", "accepted", "mean_x",
                  "mean_y", "rms", "median|e|", "p90|e|");
    text += line;
    std::size_t levelIndex = 0;
    for (const LevelOffsets& l : result.offsets) {
      if (l.dx.empty()) continue;  // perLevel holds the levels with correspondences, in order
      nlohmann::json& entry = perLevel.at(levelIndex++);
      entry["align_tried"] = l.alignTried;
      entry["align_accepted"] = l.alignedDx.size();
      if (l.alignedDx.empty()) continue;
      const OffsetSummary a = summarize(l.alignedDx, l.alignedDy);
      entry["aligned_mean_x_level_px"] = a.meanX;
      entry["aligned_mean_y_level_px"] = a.meanY;
      entry["aligned_rms_level_px"] = a.rms;
      entry["aligned_median_norm_level_px"] = a.median;
      entry["aligned_p90_norm_level_px"] = a.p90;
      std::snprintf(line, sizeof line, "%5d %8zu %9zu %+8.3f %+8.3f %8.3f %10.3f %9.3f\n", l.level, l.alignTried,
                    l.alignedDx.size(), a.meanX, a.meanY, a.rms, a.median, a.p90);
      text += line;
    }
  }
  nlohmann::json pairs = nlohmann::json::array();
  for (const PairCounts& c : result.pairs) pairs.push_back(toJson(c));
  result.report = {{"tool", "match-oracle"},
                   {"rawlog", o.rawlog.string()},
                   {"ground_truth", gtPath.string()},
                   {"config", o.config.string()},
                   {"overrides", o.overrides},
                   {"options",
                    {{"steps", o.steps},
                     {"radius_px", o.radius},
                     {"max_hamming", o.maxHamming},
                     {"ratio", o.ratio},
                     {"depth_tolerance", o.depthTolerance},
                     {"max_gt_dt", o.maxGroundTruthDt},
                     {"min_matches", o.minMatches},
                     {"align", o.align}}},
                   {"orb",
                    {{"nFeatures", slam.orb.nFeatures},
                     {"nLevels", slam.orb.nLevels},
                     {"scaleFactor", slam.orb.scaleFactor}}},
                   {"frames", nFrames},
                   {"per_step", perStep},
                   {"keypoint_offsets", perLevel},
                   {"pairs", pairs}};
  result.text = text;
  if (jsonOut) writeOutputFile(*jsonOut, [&](std::ostream& os) { os << result.report.dump(2) << "\n"; });
  if (plotOut) {
    eval::Plot plot("ORB correspondences between frames k and k+1 (ground truth)", "frame k", "keypoints of frame k");
    std::vector<double> k, visible, repeated, matchable, found;
    for (const PairCounts& c : result.pairs) {
      if (c.step != 1) continue;
      k.push_back(static_cast<double>(c.first));
      visible.push_back(static_cast<double>(c.visible));
      repeated.push_back(static_cast<double>(c.repeated));
      matchable.push_back(static_cast<double>(c.matchable));
      found.push_back(static_cast<double>(c.foundByDescriptor));
    }
    plot.addLine(k, visible, "visible", eval::colors::grey(), 1);
    plot.addLine(k, repeated, "repeated (keypoint within the radius)", eval::colors::blue());
    plot.addLine(k, matchable, "matchable (descriptor within the threshold)", eval::colors::green());
    plot.addLine(k, found, "found by the whole-image nearest neighbour", eval::colors::orange());
    if (!k.empty())
      plot.addLine({k.front(), k.back()}, {static_cast<double>(o.minMatches), static_cast<double>(o.minMatches)},
                   std::to_string(o.minMatches) + " (--min-matches)", eval::colors::red(), 1);
    plot.setYRange(0, std::max(1.0, visible.empty() ? 1.0 : *std::max_element(visible.begin(), visible.end())) * 1.05);
    plot.save(plotOut->tempPath());
  }
  outputs.commit();
  return result;
}

}  // namespace pslam::features
