// Stand-in consumer of the installed package while examples/minimal_slam.cpp cannot link yet (the System
// façade's implementation is not in this tree): same command line and output shape, through API that exists
// (config loading, the rawlog reader, the map container and its file IO).
//   rawlog_map_io <config.ini> <in.rawlog> [map-out.slammap]
#include <cstdlib>
#include <exception>
#include <iostream>

#include <nlohmann/json.hpp>

#include "pslam/datasets/Rawlog.h"
#include "pslam/map/Map.h"
#include "pslam/map/MapIO.h"
#include "pslam/system/SlamParams.h"

int main(int argc, char** argv) {
  if (argc < 3 || argc > 4) {
    std::cerr << "usage: rawlog_map_io <config.ini> <in.rawlog> [map-out.slammap]\n";
    return 2;
  }
  try {
    const pslam::system::SlamParams params = pslam::system::loadSlamParams(argv[1]);
    (void)params;
    pslam::datasets::RawlogReader reader(argv[2]);
    pslam::datasets::Frame frame;
    std::size_t frames = 0;
    while (reader.next(frame)) {
      pslam::datasets::validateFrame(frame, "frame " + std::to_string(frame.index));
      std::cout << frame.index << " read " << frame.image.cols << "x" << frame.image.rows << "\n";
      ++frames;
    }
    const std::string mapPath = argc == 4 ? argv[3] : "map.slammap";
    pslam::map::saveMap(pslam::map::Map{}, mapPath);
    const pslam::map::Map back = pslam::map::loadMap(mapPath);
    nlohmann::json summary{{"frames", frames}, {"keyframes", back.numKeyFrames()}, {"map_points", back.numMapPoints()}};
    std::cout << "summary " << summary.dump() << "\n";
    return EXIT_SUCCESS;
  } catch (const std::exception& e) {
    std::cerr << "rawlog_map_io: error: " << e.what() << "\n";
    return EXIT_FAILURE;
  }
}
