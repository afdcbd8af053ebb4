#include "pslam/priors/NormalSource.h"

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

void NormalSourceParams::resolvePaths(const fs::path& iniPath) {
  if (!iniPath.empty()) network.resolvePaths(fs::absolute(iniPath).parent_path().string());
}

std::unique_ptr<NormalSource> makeNormalSource(const std::string& kind, const NormalSourceParams& params) {
  if (kind == "rawlog") return std::make_unique<RawlogNormals>();
  if (kind == "depth") return std::make_unique<DepthNormals>(params.depth);
  if (kind != "network") throw Error("normal source '" + kind + "': must be one of rawlog, depth, network");
  require(!params.network.model.empty(), "normal source 'network'",
          "needs a config file with a [" + std::string(kNetworkNormalsSection) + "] section naming the model");
  return std::make_unique<NetworkNormals>(params.network);
}

std::unique_ptr<NormalSource> makeNormalSource(const std::string& kind, const fs::path& iniPath) {
  NormalSourceParams p;
  if (!iniPath.empty()) {
    params::loadSectionsFromFile(p, iniPath.string());
    p.resolvePaths(iniPath);
    if (kind == "network" && p.network.model.empty())
      throw Error(iniPath.string() + ": [" + kNetworkNormalsSection +
                  "] model: missing (the network normal source needs it)");
  }
  return makeNormalSource(kind, p);
}

}  // namespace pslam::priors
