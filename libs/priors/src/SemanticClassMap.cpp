#include "pslam/priors/SemanticClassMap.h"

#include <algorithm>
#include <cctype>
#include <sstream>

#include <mrpt/config/CConfigFile.h>
#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Error.h"

namespace pslam::priors {

SemanticClass parseSemanticClass(const std::string& text, const std::string& context) {
  std::string t = text;
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return std::tolower(c); });
  if (t == "static") return SemanticClass::Static;
  if (t == "dynamic") return SemanticClass::Dynamic;
  if (t == "invalid") return SemanticClass::Invalid;
  throw Error(context + ": group '" + text + "' unknown (expected static, dynamic or invalid)");
}

std::string toString(SemanticClass c) {
  switch (c) {
    case SemanticClass::Static: return "static";
    case SemanticClass::Dynamic: return "dynamic";
    case SemanticClass::Invalid: return "invalid";
  }
  return "unknown";
}

SemanticClassMap SemanticClassMap::cityscapes() {
  // Table 3.1, trainId order of the Cityscapes benchmark (and of ENet's categories.txt).
  using S = SemanticClass;
  SemanticClassMap m;
  m.name = "cityscapes";
  const std::vector<std::pair<const char*, S>> classes = {
      {"road", S::Static},         {"sidewalk", S::Static},     {"building", S::Static}, {"wall", S::Static},
      {"fence", S::Static},        {"pole", S::Static},         {"traffic light", S::Static},
      {"traffic sign", S::Static}, {"vegetation", S::Static},   {"terrain", S::Static},  {"sky", S::Invalid},
      {"person", S::Dynamic},      {"rider", S::Dynamic},       {"car", S::Dynamic},     {"truck", S::Dynamic},
      {"bus", S::Dynamic},         {"train", S::Dynamic},       {"motorcycle", S::Dynamic},
      {"bicycle", S::Dynamic}};
  for (const auto& [n, g] : classes) {
    m.classNames.emplace_back(n);
    m.groups.push_back(g);
  }
  m.unlabeled = S::Invalid;  // trainId 255: ego vehicle, rectification border, unlabeled
  return m;
}

SemanticClassMap SemanticClassMap::loadFromFile(const std::filesystem::path& iniPath) {
  if (!std::filesystem::is_regular_file(iniPath))
    throw Error(iniPath.string() + ": class map file not found");
  mrpt::config::CConfigFile cfg(iniPath.string());
  SemanticClassMap m;
  try {
    m.loadFromConfigFile(cfg, "SemanticClassMap");
  } catch (const Error& e) {
    throw Error(iniPath.string() + ": " + e.what());
  }
  return m;
}

void SemanticClassMap::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section) {
  const std::string ctx = "[" + section + "]";
  name = cfg.read_string(section, "name", "");
  const int n = cfg.read_int(section, "numClasses", 0);
  if (n <= 0 || n > 256) throw Error(ctx + " numClasses: must be in [1, 256]");
  unlabeled = parseSemanticClass(cfg.read_string_first_word(section, "unlabeled", "invalid"), ctx + " unlabeled");
  const std::string defaultText = cfg.read_string_first_word(section, "default", "");
  classNames.assign(n, "");
  groups.assign(n, SemanticClass::Static);
  for (int i = 0; i < n; ++i) {
    const std::string key = "class" + std::to_string(i);
    std::string value = cfg.read_string(section, key, "");
    value = value.substr(0, value.find(';'));  // inline comment
    value.erase(value.find_last_not_of(" \t") + 1);
    if (value.empty()) {
      if (defaultText.empty()) throw Error(ctx + " " + key + ": missing (and no 'default' group given)");
      classNames[i] = "class" + std::to_string(i);
      groups[i] = parseSemanticClass(defaultText, ctx + " default");
      continue;
    }
    // "<name words...> <group>": the last word is the group, the rest (may contain spaces) the name.
    const auto lastSpace = value.find_last_of(" \t");
    if (lastSpace == std::string::npos) throw Error(ctx + " " + key + ": expected '<name> <group>'");
    std::string className = value.substr(0, lastSpace);
    className.erase(className.find_last_not_of(" \t") + 1);
    classNames[i] = className;
    groups[i] = parseSemanticClass(value.substr(lastSpace + 1), ctx + " " + key);
  }
  check();
}

void SemanticClassMap::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& section) const {
  cfg.write(section, "name", name);
  cfg.write(section, "numClasses", numClasses());
  cfg.write(section, "unlabeled", toString(unlabeled));
  for (int i = 0; i < numClasses(); ++i)
    cfg.write(section, "class" + std::to_string(i), classNames[i] + " " + toString(groups[i]));
}

void SemanticClassMap::check() const {
  if (classNames.empty()) throw Error("SemanticClassMap '" + name + "': numClasses must be > 0");
  if (classNames.size() != groups.size()) throw Error("SemanticClassMap '" + name + "': names and groups differ in size");
  if (classNames.size() > 256) throw Error("SemanticClassMap '" + name + "': numClasses must be <= 256");
}

SemanticClass SemanticClassMap::groupOf(int label) const {
  return (label >= 0 && label < numClasses()) ? groups[label] : unlabeled;
}

cv::Mat SemanticClassMap::groupLookupTable() const {
  cv::Mat lut(1, 256, CV_8U);
  for (int v = 0; v < 256; ++v) lut.at<uchar>(v) = static_cast<uchar>(groupOf(v));
  return lut;
}

}  // namespace pslam::priors
