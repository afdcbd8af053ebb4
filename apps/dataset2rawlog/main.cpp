// dataset2rawlog: converts a dataset on disk into the project's rawlog contract + TUM ground truth.
// Thin CLI around pslam::datasets::Dataset2RawlogApp (libs/datasets); see doc/datasets.md.
#include <cstdio>
#include <exception>
#include <string>

#include <CLI/CLI.hpp>

#include "pslam/core/Error.h"
#include "pslam/core/Params.h"
#include "pslam/datasets/Dataset2RawlogApp.h"

int main(int argc, char** argv) {
  using pslam::datasets::Dataset2RawlogOptions;
  Dataset2RawlogOptions opt;
  // Command-line values: the parsing and rule of the option's key (Dataset2RawlogOptions::visitFields).
  const auto key = [](const char* k) { return pslam::params::cliCheckKey<Dataset2RawlogOptions>(k); };
  std::string intrinsics, distortion;
  bool quiet = false;

  CLI::App app{
      "dataset2rawlog: convert a dataset into an MRPT rawlog (CAMERA [+ DEPTH], images in <name>_Images/) and a\n"
      "TUM ground-truth file <name>_groundtruth.txt (camera-to-world, stamps = CAMERA stamps).\n"
      "Formats: tum (rgb.txt, depth.txt, groundtruth.txt), icl (ICL-NUIM TUM-compatible: associations.txt,\n"
      "*.gt.freiburg), kitti (sequences/NN: image_0|image_2, calib.txt, times.txt, ../../poses/NN.txt),\n"
      "euroc (mav0/cam0, state_groundtruth_estimate0), folder (images + --intrinsics/--camera-ini + --rate).\n"
      "Example: dataset2rawlog data/kitti/sequences/00 -o rawlogs --camera-ini config/cameras/kitti_00-02.ini\n"
      "Details: doc/datasets.md"};
  app.add_option("input", opt.input, "Dataset folder")->required();
  app.add_option("-o,--out-dir", opt.outDir, "Output folder")->required();
  app.add_option("--name", opt.name, "Output base name (default: sequence folder name, kitti_<seq> for KITTI)")
      ->check(key("name"));
  app.add_option("--format", opt.format, "auto|tum|icl|kitti|euroc|folder")->check(key("format"))->capture_default_str();
  app.add_option("--first", opt.first, "First frame to convert (0-based)")->check(key("first"))->capture_default_str();
  app.add_option("--last", opt.last, "Last frame to convert (inclusive)")->check(key("last"));
  app.add_option("--count", opt.count, "Convert at most this many frames (after --stride; 0 = all)")
      ->check(key("count"))->capture_default_str();
  app.add_option("--stride", opt.stride, "Keep every n-th frame")->check(key("stride"))->capture_default_str();
  app.add_option("--color", opt.color, "keep|grey|colour: CAMERA image colour")->check(key("color"))->capture_default_str();
  app.add_option("--image-format", opt.imageFormat, "Lossless image format: png|bmp|tiff|ppm|pgm")
      ->check(key("image_format"))
      ->capture_default_str();
  app.add_option("--camera-ini", opt.cameraIni,
                 "MRPT TCamera ini file (e.g. config/cameras/kitti_00-02.ini); overrides the dataset's intrinsics");
  app.add_option("--camera-section", opt.cameraSection, "Section of --camera-ini")->capture_default_str();
  app.add_option("--intrinsics", intrinsics, "fx,fy,cx,cy (resolution from the first image)");
  app.add_option("--distortion", distortion, "k1,k2,p1,p2[,k3] (plumb_bob) with --intrinsics");
  app.add_option("--tum-camera", opt.tumCamera, "fr1|fr2|fr3 TUM calibration (default: from the folder name)")
      ->check(key("tum_camera"));
  app.add_option("--rate", opt.rate,
                 "Frame rate in Hz: KITTI without times.txt, ICL-NUIM (default 30), image folder (required)")
      ->check(key("rate"));
  app.add_option("--first-stamp", opt.firstStamp, "Timestamp of the first image, seconds (image folder)")
      ->check(key("first_stamp"));
  app.add_option("--max-depth-diff", opt.maxDepthDiff, "TUM RGB/depth association window in s (associate.py)")
      ->check(key("max_depth_diff"))
      ->capture_default_str();
  app.add_option("--gt-max-gap", opt.gtMaxGap, "Do not interpolate ground truth across holes longer than this (s)")
      ->check(key("gt_max_gap"));
  app.add_flag("--no-depth", opt.noDepth, "Do not write DEPTH observations");
  app.add_option("--euroc-camera", opt.eurocCamera, "EuRoC camera folder (cam0 or cam1)")
      ->check(key("euroc_camera"))
      ->capture_default_str();
  app.add_option("--kitti-camera", opt.kittiCamera, "KITTI camera: 0 (image_0, grey) or 2 (image_2, colour)")
      ->check(key("kitti_camera"));
  app.add_option("--poses", opt.posesFile,
                 "Ground-truth file: KITTI poses (3x4 per line), ICL *.gt.freiburg, or TUM file for a folder (one "
                 "pose per image)");
  app.add_option("--times", opt.timesFile, "KITTI times file (instead of <seq>/times.txt)");
  app.add_flag("--icl-raw-poses", opt.iclRawPoses, "Keep ICL-NUIM poses in the renderer's y-up frame (no S T S)");
  app.add_flag("-q,--quiet", quiet, "No progress and no summary on the terminal");

  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }

  try {
    if (!intrinsics.empty()) opt.intrinsics = pslam::datasets::parseNumberList(intrinsics, "--intrinsics");
    if (!distortion.empty()) opt.distortion = pslam::datasets::parseNumberList(distortion, "--distortion");
    opt.progress = !quiet;
    pslam::datasets::Dataset2RawlogApp converter(opt);
    const auto summary = converter.run();
    if (!quiet) {
      for (const auto& a : summary.assumptions) std::printf("dataset2rawlog: assumed: %s\n", a.c_str());
      const auto timings = summary.timings.summary();
      for (auto it = timings.begin(); it != timings.end(); ++it)
        std::printf("dataset2rawlog: timing %-5s mean %.1f ms/frame, median %.1f, total %.2f s\n", it.key().c_str(),
                    it.value().at("mean_ms").get<double>(), it.value().at("median_ms").get<double>(),
                    it.value().at("total_ms").get<double>() / 1000.0);
      std::printf("dataset2rawlog: %s %s\n", summary.format.c_str(), summary.line().c_str());
      if (!summary.groundTruthPath.empty())
        std::printf("dataset2rawlog: ground truth -> %s\n", summary.groundTruthPath.string().c_str());
    }
    return 0;
  } catch (const std::exception& e) {
    std::string msg = e.what();
    const auto nl = msg.find('\n');
    if (nl != std::string::npos) msg = msg.substr(0, nl);
    std::fprintf(stderr, "dataset2rawlog: error: %s\n", msg.c_str());
    return 1;
  }
}
