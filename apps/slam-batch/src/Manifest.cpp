#include "pslam/batch/Manifest.h"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cstdio>
#include <map>
#include <regex>
#include <set>
#include <sstream>

#include "pslam/core/AtomicFile.h"
#include "pslam/core/Error.h"
#include "pslam/system/SlamParams.h"

namespace pslam::batch {
namespace fs = std::filesystem;

std::string fnv1aHex(const std::string& text) {
  std::uint64_t h = 1469598103934665603ULL;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ULL;
  }
  char buf[17];
  std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(h));
  return buf;
}

const RunSpec* Manifest::findRun(const std::string& id) const {
  for (const RunSpec& r : runs)
    if (r.id == id) return &r;
  return nullptr;
}

namespace {

/// Errors of one manifest file: "<file>: line L: <message>" (yaml-cpp marks are 0-based).
struct Reader {
  fs::path file;

  [[noreturn]] void fail(const YAML::Node& node, const std::string& message) const {
    const YAML::Mark m = node.Mark();
    if (m.is_null()) throw Error(file.string() + ": " + message);
    throw Error(file.string() + ": line " + std::to_string(m.line + 1) + ": " + message);
  }

  void requireMap(const YAML::Node& node, const std::string& what) const {
    if (!node.IsMap()) fail(node, what + " must be a mapping of keys to values");
  }

  /// Unknown keys are errors that list the known ones; so is a key given twice (YAML readers keep one of the two,
  /// so the other would be ignored without a word).
  void onlyKeys(const YAML::Node& node, const std::string& where, const std::vector<std::string>& known) const {
    std::map<std::string, YAML::Mark> seen;
    for (const auto& kv : node) {
      const std::string key = kv.first.as<std::string>();
      if (const auto [it, fresh] = seen.emplace(key, kv.first.Mark()); !fresh)
        fail(kv.first, "key '" + key + "' given twice in " + where +
                           (it->second.is_null() ? std::string() : " (first on line " + std::to_string(it->second.line + 1) + ")"));
      if (std::find(known.begin(), known.end(), key) == known.end()) {
        std::string list;
        for (const std::string& k : known) list += (list.empty() ? "" : ", ") + k;
        fail(kv.first, "unknown key '" + key + "' in " + where + " (known: " + list + ")");
      }
    }
  }

  std::string string(const YAML::Node& node, const std::string& what) const {
    if (!node.IsScalar()) fail(node, what + " must be a single value");
    return node.as<std::string>();
  }

  template <class T>
  T number(const YAML::Node& node, const std::string& what, const std::string& expected) const {
    if (!node.IsScalar()) fail(node, what + " must be " + expected);
    T value{};
    if (!YAML::convert<T>::decode(node, value)) fail(node, what + " = '" + node.Scalar() + "': not " + expected);
    return value;
  }

  bool boolean(const YAML::Node& node, const std::string& what) const {
    return number<bool>(node, what, "true or false");
  }

  std::vector<std::string> stringList(const YAML::Node& node, const std::string& what) const {
    std::vector<std::string> out;
    if (node.IsScalar()) {
      out.push_back(node.as<std::string>());
      return out;
    }
    if (!node.IsSequence()) fail(node, what + " must be a list of Section.key=value");
    for (const auto& item : node) out.push_back(string(item, what + " entry"));
    return out;
  }

  std::string name(const YAML::Node& node, const std::string& what) const {
    static const std::regex ok("[A-Za-z0-9][A-Za-z0-9._-]*");
    const std::string n = string(node, what);
    if (!std::regex_match(n, ok))
      fail(node, what + " '" + n + "': use letters, digits, '.', '_' and '-' (it names a folder)");
    return n;
  }

  fs::path path(const YAML::Node& node, const std::string& what, const fs::path& base) const {
    const std::string text = string(node, what);
    if (text.empty()) fail(node, what + " is empty");
    fs::path p(text);
    if (p.is_relative()) p = base / p;
    return p.lexically_normal();
  }

  fs::path existingFile(const YAML::Node& node, const std::string& what, const fs::path& base) const {
    const fs::path p = path(node, what, base);
    std::error_code ec;
    if (!fs::is_regular_file(p, ec)) fail(node, what + " " + p.string() + ": file not found");
    return p;
  }
};

template <class Enum>
Enum enumValue(const Reader& rd, const YAML::Node& node, const std::string& what) {
  const std::string text = rd.string(node, what);
  std::string list;
  for (const auto& [value, name] : eval::enumNames(Enum{})) {
    if (text == name) return value;
    list += (list.empty() ? "" : " | ") + std::string(name);
  }
  rd.fail(node, what + " '" + text + "': expected " + list);
}

/// What identifies the input of a run for the resume check: the rawlog's path, size and modification time.
std::string rawlogIdentity(const fs::path& rawlog) {
  std::error_code ec;
  const auto size = fs::file_size(rawlog, ec);
  const auto mtime = fs::last_write_time(rawlog, ec).time_since_epoch().count();
  return fs::weakly_canonical(rawlog).string() + " " + std::to_string(size) + " " + std::to_string(mtime);
}

}  // namespace

Manifest loadManifest(const fs::path& fileIn, const fs::path& outputOverride) {
  Manifest m;
  m.file = fs::absolute(fileIn).lexically_normal();
  Reader rd{fileIn};
  std::error_code ec;
  if (!fs::is_regular_file(m.file, ec)) throw Error(fileIn.string() + ": manifest not found");
  YAML::Node loaded;
  try {
    loaded = YAML::LoadFile(m.file.string());
  } catch (const YAML::Exception& e) {
    throw Error(fileIn.string() + ": line " + std::to_string(e.mark.line + 1) + ": not valid YAML (" + e.msg + ")");
  }
  const YAML::Node root = loaded;  // const: looking a key up never adds it
  if (!root.IsDefined() || root.IsNull()) throw Error(fileIn.string() + ": empty manifest");
  rd.requireMap(root, "the manifest");
  rd.onlyKeys(root, "the manifest",
              {"name", "base", "output", "slam_run", "datasets", "variants", "seeds", "evaluation"});

  const fs::path fileDir = m.file.parent_path();
  m.base = root["base"] ? rd.path(root["base"], "base", fileDir) : fileDir;
  m.name = root["name"] ? rd.name(root["name"], "name") : m.file.stem().string();
  if (!outputOverride.empty())
    m.output = fs::absolute(outputOverride).lexically_normal();
  else if (root["output"])
    m.output = rd.path(root["output"], "output", m.base);
  else
    rd.fail(root, "no 'output' folder given (or pass --out)");
  if (root["slam_run"]) m.slamRun = rd.existingFile(root["slam_run"], "slam_run", m.base);

  // ---- datasets
  const YAML::Node ds = root["datasets"];
  if (!ds || !ds.IsSequence() || ds.size() == 0) rd.fail(ds ? ds : root, "'datasets' must be a non-empty list");
  std::set<std::string> names;
  for (std::size_t i = 0; i < ds.size(); ++i) {
    const YAML::Node d = ds[i];
    const std::string where = "datasets[" + std::to_string(i) + "]";
    rd.requireMap(d, where);
    rd.onlyKeys(d, where, {"name", "rawlog", "groundtruth", "config", "set", "first", "last"});
    for (const char* k : {"name", "rawlog", "groundtruth"})
      if (!d[k]) rd.fail(d, where + ": '" + k + "' is required");
    DatasetSpec spec;
    spec.name = rd.name(d["name"], where + ".name");
    if (!names.insert(spec.name).second) rd.fail(d["name"], "duplicate dataset name '" + spec.name + "'");
    spec.rawlog = rd.existingFile(d["rawlog"], where + ".rawlog", m.base);
    spec.groundTruth = rd.existingFile(d["groundtruth"], where + ".groundtruth", m.base);
    if (d["config"]) spec.config = rd.existingFile(d["config"], where + ".config", m.base);
    if (d["set"]) spec.overrides = rd.stringList(d["set"], where + ".set");
    if (d["first"]) spec.first = rd.number<long long>(d["first"], where + ".first", "a frame index >= 0");
    if (d["last"]) spec.last = rd.number<long long>(d["last"], where + ".last", "a frame index >= 0");
    if (spec.first && *spec.first < 0) rd.fail(d["first"], where + ".first must be >= 0");
    if (spec.last && (*spec.last < 0 || *spec.last < spec.first.value_or(0)))
      rd.fail(d["last"], where + ".last must be >= first");
    m.datasets.push_back(std::move(spec));
  }

  // ---- variants
  const YAML::Node vs = root["variants"];
  if (!vs || !vs.IsSequence() || vs.size() == 0) rd.fail(vs ? vs : root, "'variants' must be a non-empty list");
  names.clear();
  for (std::size_t i = 0; i < vs.size(); ++i) {
    const YAML::Node v = vs[i];
    const std::string where = "variants[" + std::to_string(i) + "]";
    rd.requireMap(v, where);
    rd.onlyKeys(v, where, {"name", "config", "set"});
    if (!v["name"]) rd.fail(v, where + ": 'name' is required");
    VariantSpec spec;
    spec.name = rd.name(v["name"], where + ".name");
    if (!names.insert(spec.name).second) rd.fail(v["name"], "duplicate variant name '" + spec.name + "'");
    if (v["config"]) spec.config = rd.existingFile(v["config"], where + ".config", m.base);
    if (v["set"]) spec.overrides = rd.stringList(v["set"], where + ".set");
    m.variants.push_back(std::move(spec));
  }

  // ---- seeds
  const YAML::Node ss = root["seeds"];
  if (!ss) {
    m.seeds = {0};
  } else {
    if (!ss.IsSequence() || ss.size() == 0) rd.fail(ss, "'seeds' must be a non-empty list of integers >= 0");
    for (const auto& s : ss) {
      const long long v = rd.number<long long>(s, "seed", "an integer >= 0");
      if (v < 0 || v > 0xffffffffLL) rd.fail(s, "seed " + std::to_string(v) + " is out of range [0, 2^32)");
      if (std::find(m.seeds.begin(), m.seeds.end(), static_cast<std::uint32_t>(v)) != m.seeds.end())
        rd.fail(s, "duplicate seed " + std::to_string(v));
      m.seeds.push_back(static_cast<std::uint32_t>(v));
    }
  }

  // ---- evaluation
  if (const YAML::Node e = root["evaluation"]) {
    rd.requireMap(e, "evaluation");
    rd.onlyKeys(e, "evaluation", {"align", "association", "max_time_difference", "depth_ratio"});
    if (e["align"]) m.evaluation.alignment = enumValue<eval::AlignmentMode>(rd, e["align"], "evaluation.align");
    if (e["association"])
      m.evaluation.association = enumValue<eval::AssociationRule>(rd, e["association"], "evaluation.association");
    if (e["max_time_difference"]) {
      m.evaluation.maxTimeDifference =
          rd.number<double>(e["max_time_difference"], "evaluation.max_time_difference", "a number of seconds");
      if (!(m.evaluation.maxTimeDifference >= 0) || !std::isfinite(m.evaluation.maxTimeDifference))
        rd.fail(e["max_time_difference"], "evaluation.max_time_difference must be a finite number >= 0");
    }
    if (e["depth_ratio"]) m.evaluation.depthRatio = rd.boolean(e["depth_ratio"], "evaluation.depth_ratio");
  }

  // ---- runs: every dataset x variant configuration is loaded now, so a bad one fails before any run.
  for (std::size_t di = 0; di < m.datasets.size(); ++di) {
    const DatasetSpec& d = m.datasets[di];
    const std::string rawlogId = rawlogIdentity(d.rawlog);
    for (std::size_t vi = 0; vi < m.variants.size(); ++vi) {
      const VariantSpec& v = m.variants[vi];
      RunSpec base;
      base.datasetIndex = di;
      base.variantIndex = vi;
      base.config = v.config.empty() ? d.config : v.config;
      if (base.config.empty())
        rd.fail(vs[vi], "variant '" + v.name + "' has no config and dataset '" + d.name + "' gives none");
      base.overrides = d.overrides;
      base.overrides.insert(base.overrides.end(), v.overrides.begin(), v.overrides.end());
      try {
        const system::SlamParams params = system::loadSlamParams(base.config.string(), base.overrides);
        base.effectiveConfig = params.toIniText();
        base.threaded = params.system.threaded;
      } catch (const std::exception& e) {
        rd.fail(vs[vi], "dataset '" + d.name + "' x variant '" + v.name + "': " + oneLineMessage(e));
      }
      for (std::uint32_t seed : m.seeds) {
        RunSpec r = base;
        r.seed = seed;
        r.id = d.name + "/" + v.name + "/seed-" + std::to_string(seed);
        std::ostringstream key;
        key << "slam-batch run v1\nrawlog " << rawlogId << "\nseed " << seed << "\nfirst "
            << d.first.value_or(0) << "\nlast " << d.last.value_or(-1) << "\nconfig\n"
            << r.effectiveConfig;
        r.hash = fnv1aHex(key.str());
        m.runs.push_back(std::move(r));
      }
    }
  }
  // ---- outputs: collect's files and the run folders may never be an input (a ground truth stored as
  // <output>/results.csv was overwritten by the collect of `run`).
  const std::vector<fs::path> inputs = manifestInputs(m);
  for (const fs::path& out : collectOutputs(m)) requireNotAnInput(out, OutputKind::file(), inputs);
  return m;
}

std::vector<fs::path> manifestInputs(const Manifest& m) {
  std::vector<fs::path> in{m.file};
  if (!m.slamRun.empty()) in.push_back(m.slamRun);
  for (const DatasetSpec& d : m.datasets) {
    in.insert(in.end(), {d.rawlog, d.rawlog.parent_path() / (d.rawlog.stem().string() + "_Images"), d.groundTruth,
                         d.config});
  }
  for (const VariantSpec& v : m.variants) in.push_back(v.config);
  return in;
}

std::vector<fs::path> collectOutputs(const Manifest& m) {
  std::vector<fs::path> out{m.output / "results.csv", m.output / "results.json", m.output / "summary.md"};
  for (const DatasetSpec& d : m.datasets) out.push_back(m.output / ("ate_" + d.name + ".png"));
  return out;
}

}  // namespace pslam::batch
