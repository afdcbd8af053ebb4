// image_folder_slam: monocular SLAM on a folder of images, without any rawlog (doc/api.md).
//   image_folder_slam <config.ini> <camera.ini> <image-folder> [fps] [trajectory-out.txt]
// <camera.ini>: an MRPT TCamera block in section [CAMERA] (config/cameras/*.ini). The images (PNG or JPEG, grey
// or colour) are taken in file-name order, frame k at k / fps seconds (fps 30 by default). Prints one line per
// frame (index, status, and the camera position when tracked), then writes the trajectory (TUM format) and a
// summary line.
#include <algorithm>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include <mrpt/config/CConfigFile.h>
#include <opencv2/imgcodecs.hpp>

#include "pslam/geometry/PinholeCamera.h"
#include "pslam/system/System.h"

namespace fs = std::filesystem;

int main(int argc, char** argv) {
  if (argc < 4 || argc > 6) {
    std::cerr << "usage: image_folder_slam <config.ini> <camera.ini> <image-folder> [fps] [trajectory-out.txt]\n";
    return 2;
  }
  try {
    const fs::path config = argv[1], cameraIni = argv[2], folder = argv[3];
    const double fps = argc >= 5 ? std::stod(argv[4]) : 30.0;
    const fs::path trajectoryOut = argc >= 6 ? argv[5] : "trajectory.txt";
    if (!(fps > 0.0)) throw std::runtime_error(std::string(argv[4]) + ": fps must be > 0");
    if (!fs::is_regular_file(cameraIni)) throw std::runtime_error(cameraIni.string() + ": camera file not found");
    if (!fs::is_directory(folder)) throw std::runtime_error(folder.string() + ": image folder not found");

    std::vector<fs::path> images;
    for (const fs::directory_entry& e : fs::directory_iterator(folder)) {
      std::string ext = e.path().extension().string();
      std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
      if (e.is_regular_file() && (ext == ".png" || ext == ".jpg" || ext == ".jpeg")) images.push_back(e.path());
    }
    std::sort(images.begin(), images.end());
    if (images.empty()) throw std::runtime_error(folder.string() + ": no PNG or JPEG image");

    pslam::system::SystemOptions options;
    options.camera = pslam::geometry::PinholeCamera::loadFromConfigFile(mrpt::config::CConfigFile(cameraIni.string()),
                                                                        "CAMERA");
    pslam::system::System slam(config, {}, options);
    for (std::size_t k = 0; k < images.size(); ++k) {
      const cv::Mat image = cv::imread(images[k].string(), cv::IMREAD_UNCHANGED);
      if (image.empty()) throw std::runtime_error(images[k].string() + ": not a readable image");
      const pslam::system::FrameResult r = slam.track(image, static_cast<double>(k) / fps);
      std::cout << k << " " << pslam::system::toString(r.state);
      if (r.pose) std::cout << " " << r.pose->x() << " " << r.pose->y() << " " << r.pose->z();
      std::cout << "\n";
    }
    slam.finish();
    slam.saveTrajectory(trajectoryOut);
    const pslam::system::RunSummary s = slam.summary();
    std::cout << "summary " << s.framesTracked << " of " << s.framesProcessed << " frames tracked, " << s.keyFrames
              << " keyframes; trajectory in " << trajectoryOut.string() << "\n";
    return EXIT_SUCCESS;
  } catch (const std::exception& e) {
    std::cerr << "image_folder_slam: error: " << e.what() << "\n";
    return EXIT_FAILURE;
  }
}
