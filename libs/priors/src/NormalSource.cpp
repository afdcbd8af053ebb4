#include "pslam/priors/NormalSource.h"

#include <mrpt/config/CConfigFile.h>

#include "pslam/core/Error.h"
#include "pslam/priors/NormalsFromDepth.h"
#include "pslam/priors/NormalsFromNetwork.h"

namespace fs = std::filesystem;

namespace pslam::priors {

namespace {

std::string frameCtx(const datasets::Frame& f) { return "frame " + std::to_string(f.index); }

class RawlogNormals final : public NormalSource {
 public:
  NormalMap compute(const datasets::Frame& f) override {
    require(f.hasNormals(), frameCtx(f), "has no NORMALS channel");
    NormalMap m;
    m.normals = decodeNormalMap(f.normals, frameCtx(f) + " NORMALS");
    // The contract stores (0,0,0) for "no normal / not planar": every stored normal is planar.
    m.planarMask = cv::Mat(f.normals.size(), CV_8UC1, cv::Scalar(0));
    for (int v = 0; v < m.normals.rows; ++v) {
      const auto* n = m.normals.ptr<cv::Vec3f>(v);
      uchar* o = m.planarMask.ptr<uchar>(v);
      for (int u = 0; u < m.normals.cols; ++u)
        if (n[u] != cv::Vec3f(0, 0, 0)) o[u] = 255;
    }
    return m;
  }
  std::string kind() const override { return "rawlog"; }
};

class DepthNormals final : public NormalSource {
 public:
  explicit DepthNormals(DepthNormalParams p) : estimator_(p) {}
  NormalMap compute(const datasets::Frame& f) override {
    require(f.hasDepth(), frameCtx(f), "has no DEPTH channel (needed for normals from depth)");
    return estimator_.computeFromRaw(f.depth, f.depthUnits, PinholeIntrinsics::fromCamera(f.camera));
  }
  std::string kind() const override { return "depth"; }

 private:
  DepthNormalEstimator estimator_;
};

class NetworkNormals final : public NormalSource {
 public:
  explicit NetworkNormals(NetworkNormalParams p) : estimator_(std::move(p)) {}
  NormalMap compute(const datasets::Frame& f) override {
    require(!f.image.empty(), frameCtx(f), "has an empty CAMERA image");
    const PinholeIntrinsics K = PinholeIntrinsics::fromCamera(f.camera);
    return estimator_.compute(f.image, &K);
  }
  std::string kind() const override { return "network"; }

 private:
  NetworkNormalEstimator estimator_;
};

}  // namespace

std::unique_ptr<NormalSource> makeNormalSource(const std::string& kind, const fs::path& iniPath) {
  if (kind == "rawlog") return std::make_unique<RawlogNormals>();
  if (kind != "depth" && kind != "network")
    throw Error("normal source '" + kind + "': must be one of rawlog, depth, network");
  if (kind == "depth" && iniPath.empty()) return std::make_unique<DepthNormals>(DepthNormalParams{});
  require(!iniPath.empty(), "normal source 'network'", "needs an ini file with a [" +
                                                           std::string(kNetworkNormalsSection) + "] section");
  require(fs::is_regular_file(iniPath), iniPath.string(), "config file not found");
  mrpt::config::CConfigFile cfg(iniPath.string());
  try {
    if (kind == "depth") {
      DepthNormalParams p;
      p.loadFromConfigFile(cfg, kDepthNormalsSection);
      return std::make_unique<DepthNormals>(p);
    }
    require(cfg.sectionExists(kNetworkNormalsSection), iniPath.string(),
            "missing section [" + std::string(kNetworkNormalsSection) + "]");
    NetworkNormalParams p;
    p.loadFromConfigFile(cfg, kNetworkNormalsSection, iniPath.parent_path().string());
    return std::make_unique<NetworkNormals>(std::move(p));
  } catch (const Error& e) {
    throw Error(iniPath.string() + ": " + e.what());
  }
}

}  // namespace pslam::priors
