#include "pslam/datasets/Camera.h"

#include <algorithm>
#include <cctype>
#include <cmath>

#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Error.h"
#include "pslam/core/Params.h"

namespace fs = std::filesystem;

namespace pslam::datasets {

mrpt::img::TCamera makePinholeCamera(uint32_t width, uint32_t height, double fx, double fy, double cx, double cy,
                                     const std::vector<double>& distortion) {
  const std::string ctx = "camera intrinsics";
  require(width > 0 && height > 0, ctx, "image size must be positive");
  require(std::isfinite(fx) && std::isfinite(fy) && fx > 0 && fy > 0, ctx, "fx and fy must be positive");
  require(std::isfinite(cx) && std::isfinite(cy), ctx, "cx and cy must be finite");
  require(distortion.size() <= 5, ctx, "at most 5 distortion coefficients (k1 k2 p1 p2 k3)");
  mrpt::img::TCamera cam;
  cam.ncols = width;
  cam.nrows = height;
  cam.fx(fx);
  cam.fy(fy);
  cam.cx(cx);
  cam.cy(cy);
  bool any = false;
  for (std::size_t k = 0; k < distortion.size(); ++k) {
    require(std::isfinite(distortion[k]), ctx, "distortion coefficient is NaN or Inf");
    cam.dist[k] = distortion[k];
    any = any || distortion[k] != 0.0;
  }
  cam.distortion = any ? mrpt::img::DistortionModel::plumb_bob : mrpt::img::DistortionModel::none;
  return cam;
}

namespace {

// The keys of a TCamera block (mrpt::img::TCamera::loadFromConfigFile) and ours (frame_rate_hz), checked before
// MRPT reads the block: MRPT ignores unknown keys (`distortion` for distortion_model), reads `fx = abc` as 0,
// `resolution = [640 480 extra]` as 640x480. The values here only validate; MRPT's reading stays the one used.
struct CameraIniKeys {
  std::vector<double> resolution{1, 1};
  double fx = 1, fy = 1, cx = 0, cy = 0;
  std::vector<double> dist;
  std::string distortion_model = "none";
  double focal_length = 0;
  std::string camera_name;
  double frame_rate_hz = 1;

  template <class V>
  void visitFields(V& v) {
    using namespace pslam::params;
    PSLAM_FIELD(v, resolution, custom([](const std::vector<double>& r) -> std::optional<std::string> {
                  if (r.size() != 2) return "expected [width height]";
                  for (double x : r)
                    if (!(x >= 1 && x <= 65535 && x == std::floor(x)))
                      return "width and height must be whole numbers in [1, 65535]";
                  return std::nullopt;
                }, "[width height]"),
                "image size");
    PSLAM_FIELD(v, fx, greaterThan(0), "focal length x (pixels)");
    PSLAM_FIELD(v, fy, greaterThan(0), "focal length y (pixels)");
    PSLAM_FIELD(v, cx, finite(), "principal point x");
    PSLAM_FIELD(v, cy, finite(), "principal point y");
    PSLAM_FIELD(v, dist, custom([](const std::vector<double>& d) -> std::optional<std::string> {
                  if (d.size() > 8) return "at most 8 coefficients";
                  for (double x : d)
                    if (!std::isfinite(x)) return "coefficients must be finite";
                  return std::nullopt;
                }, "[k1 k2 p1 p2 k3] (plumb_bob) or [k1 k2 k3 k4] (kannala_brandt)"),
                "distortion coefficients");
    PSLAM_FIELD(v, distortion_model, oneOf({"none", "plumb_bob", "kannala_brandt"}), "distortion model");
    PSLAM_FIELD(v, focal_length, atLeast(0), "focal length in metres (optional)");
    PSLAM_FIELD(v, camera_name, anyValue, "name (optional)");
    PSLAM_FIELD(v, frame_rate_hz, greaterThan(0), "nominal frame rate (ours; TCamera ignores it)");
  }
};

/// The block [section] of a camera ini, strictly checked (file, section, key in every error); `use` gets it.
template <class F>
void readCameraIni(const fs::path& iniFile, const std::string& section, F use) {
  std::error_code ec;
  if (!fs::is_regular_file(iniFile, ec)) throw Error(iniFile.string() + ": camera ini file not found");
  // Other sections may hold other cameras (--camera-section picks one): only the block read is checked.
  params::loadConfigFile(iniFile.string(), {}, [&](const mrpt::config::CConfigFileBase& cfg) {
    if (!cfg.sectionExists(section)) throw Error("no section [" + section + "]");
    CameraIniKeys keys;
    params::load(keys, cfg, section);
    for (const char* required : {"resolution", "fx", "fy", "cx", "cy", "dist"})
      if (!cfg.keyExists(section, required))
        throw params::ParamError(section, required, std::nullopt,
                                 "missing (a TCamera block needs resolution, fx, fy, cx, cy, dist)");
    use(cfg);
  });
}

}  // namespace

mrpt::img::TCamera loadCameraIni(const fs::path& iniFile, const std::string& section) {
  mrpt::img::TCamera cam;
  readCameraIni(iniFile, section, [&](const mrpt::config::CConfigFileBase& cfg) {
    try {
      cam.loadFromConfigFile(section, cfg);
    } catch (const std::exception& e) {
      // MRPT exceptions carry a banner, a location and a call stack: keep the message, which names the key.
      std::string msg = oneLineMessage(e);
      const std::string internal = " and failIfNotFound=true.";
      if (msg.size() > internal.size() && msg.compare(msg.size() - internal.size(), internal.size(), internal) == 0)
        msg.resize(msg.size() - internal.size());
      throw Error("[" + section +
                  "]: invalid TCamera block (keys resolution, fx, fy, cx, cy, dist, distortion_model): " + msg);
    }
  });
  const std::string ctx = iniFile.string() + ": [" + section + "]";
  require(cam.ncols > 0 && cam.nrows > 0, ctx, "resolution must be positive");
  require(std::isfinite(cam.fx()) && cam.fx() > 0, ctx, "fx must be positive");
  require(std::isfinite(cam.fy()) && cam.fy() > 0, ctx, "fy must be positive");
  require(std::isfinite(cam.cx()) && std::isfinite(cam.cy()), ctx, "cx/cy must be finite");
  return cam;
}

std::optional<double> loadFrameRateFromIni(const fs::path& iniFile, const std::string& section) {
  std::optional<double> rate;
  readCameraIni(iniFile, section, [&](const mrpt::config::CConfigFileBase& cfg) {
    if (cfg.keyExists(section, "frame_rate_hz"))
      rate = params::parseValue<double>(section, "frame_rate_hz",
                                        params::valueText(cfg.read_string(section, "frame_rate_hz", "")));
  });
  return rate;
}

std::optional<std::string> tumCameraFromFolderName(const std::string& folderName) {
  std::string s = folderName;
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return std::tolower(c); });
  for (const char* k : {"1", "2", "3"}) {
    if (s.find(std::string("freiburg") + k) != std::string::npos || s.find(std::string("fr") + k + "_") != std::string::npos ||
        s.find(std::string("fr") + k + "/") != std::string::npos)
      return std::string("fr") + k;
  }
  return std::nullopt;
}

mrpt::img::TCamera tumCamera(const std::string& name) {
  std::string n = name;
  std::transform(n.begin(), n.end(), n.begin(), [](unsigned char c) { return std::tolower(c); });
  if (n.rfind("freiburg", 0) == 0) n = "fr" + n.substr(8);
  // Published by TUM (vision.in.tum.de, "file formats / intrinsic camera calibration"); distortion in the
  // OpenCV order d0..d4 = k1 k2 p1 p2 k3, which is also the order of MRPT's TCamera::dist.
  if (n == "fr1") return makePinholeCamera(640, 480, 517.3, 516.5, 318.6, 255.3, {0.2624, -0.9531, -0.0054, 0.0026, 1.1633});
  if (n == "fr2") return makePinholeCamera(640, 480, 520.9, 521.0, 325.1, 249.7, {0.2312, -0.7849, -0.0033, -0.0001, 0.9172});
  if (n == "fr3") return makePinholeCamera(640, 480, 535.4, 539.2, 320.1, 247.6);
  throw Error("TUM camera '" + name + "': unknown (use fr1, fr2 or fr3)");
}

mrpt::img::TCamera iclNuimCamera() { return makePinholeCamera(640, 480, 481.20, 480.00, 319.50, 239.50); }

}  // namespace pslam::datasets
