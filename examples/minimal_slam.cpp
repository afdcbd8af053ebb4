// minimal_slam: the smallest program that embeds priorslam through its System façade (doc/api.md).
//   minimal_slam <config.ini> <in.rawlog> [map-out.slammap]
// Feeds every frame of the rawlog, prints one line per frame (index, status and, when tracked, the camera
// pose T_world_cam as x y z yaw pitch roll), then saves the map and prints a summary.
#include <cstdlib>
#include <exception>
#include <iostream>

#include "pslam/datasets/Rawlog.h"
#include "pslam/system/System.h"

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4) {
    std::cerr << "usage: minimal_slam <config.ini> <in.rawlog> [map-out.slammap]\n";
    return 2;
  }
  try {
    pslam::system::System slam{std::filesystem::path(argv[1])};
    pslam::datasets::RawlogReader reader(argv[2]);
    pslam::datasets::Frame frame;
    while (reader.next(frame)) {
      const pslam::system::FrameResult r = slam.track(frame);
      std::cout << frame.index << " " << pslam::system::toString(r.state);
      if (r.pose) std::cout << " " << r.pose->asString();
      std::cout << "\n";
    }
    slam.finish();
    slam.saveMap(argc == 4 ? argv[3] : "map.slammap");
    const pslam::system::RunSummary s = slam.summary();
    std::cout << "summary " << s.framesTracked << " of " << s.framesProcessed << " frames tracked, " << s.keyFrames
              << " keyframes, " << s.mapPoints << " map points\n";
    return EXIT_SUCCESS;
  } catch (const std::exception& e) {
    std::cerr << "minimal_slam: error: " << e.what() << "\n";
    return EXIT_FAILURE;
  }
}
