#include "pslam/priors/SemanticClassMap.h"

#include <algorithm>
#include <cctype>
#include <optional>
#include <sstream>

#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Error.h"
#include "pslam/core/Params.h"

namespace pslam::priors {

std::string toString(SemanticClass c) {
  switch (c) {
    case SemanticClass::Static: return "static";
    case SemanticClass::Dynamic: return "dynamic";
    case SemanticClass::Invalid: return "invalid";
  }
  return "unknown";
}

namespace {
std::optional<std::string> groupProblem(const std::string& text, SemanticClass& out) {
  std::string t = text;
  std::transform(t.begin(), t.end(), t.begin(), [](unsigned char c) { return std::tolower(c); });
  if (t == "static") out = SemanticClass::Static;
  else if (t == "dynamic") out = SemanticClass::Dynamic;
  else if (t == "invalid") out = SemanticClass::Invalid;
  else return "group '" + text + "' unknown (expected static, dynamic or invalid)";
  return std::nullopt;
}
}  // namespace

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
  SemanticClassMap m;
  params::loadConfigFile(iniPath.string(), {kSection},
                         [&](const mrpt::config::CConfigFileBase& cfg) { m.loadFromConfigFile(cfg, kSection); });
  return m;
}

void SemanticClassMap::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& section) {
  // The keys are no fixed list (class0 ... classN-1): every key of that shape is taken, numClasses parsed,
  // then a class index beyond it is an error like any unknown key.
  std::vector<std::string> present, known{"name", "numClasses", "unlabeled", "default"};
  cfg.getAllKeys(section, present);
  for (const auto& k : present)
    if (k.size() > 5 && k.compare(0, 5, "class") == 0 && k.find_first_not_of("0123456789", 5) == std::string::npos)
      known.push_back(k);
  const auto values = params::sectionValues(cfg, section, known);
  if (!values.count("numClasses")) throw params::ParamError(section, "numClasses", std::nullopt, "missing");
  const int n = params::parseValue<int>(section, "numClasses", values.at("numClasses"), params::inClosed(1, 256));
  for (const auto& [k, text] : values) {
    if (k.compare(0, 5, "class") != 0) continue;
    const std::string index = k.substr(5);
    if ((index.size() > 1 && index[0] == '0') || index.size() > 3 || std::stoi(index) >= n)
      throw params::ParamError(section, k, std::nullopt,
                               "unknown key (numClasses = " + std::to_string(n) + ": class0 ... class" +
                                   std::to_string(n - 1) + ")");
  }
  const auto value = [&](const std::string& key) -> std::optional<std::string> {
    const auto it = values.find(key);
    return it == values.end() ? std::nullopt : std::optional<std::string>(it->second);
  };
  // `whole`: the key's value (named in the error), `text`: its group word.
  const auto group = [&](const std::string& key, const std::string& whole, const std::string& text) {
    SemanticClass g{};
    if (auto why = groupProblem(text, g)) throw params::ParamError(section, key, whole, *why);
    return g;
  };
  name = value("name").value_or("");
  const auto unlabeledText = value("unlabeled"), defaultText = value("default");
  unlabeled = unlabeledText ? group("unlabeled", *unlabeledText, *unlabeledText) : SemanticClass::Invalid;
  const bool hasDefault = defaultText.has_value();
  const SemanticClass defaultGroup = hasDefault ? group("default", *defaultText, *defaultText) : SemanticClass::Static;
  classNames.assign(n, "");
  groups.assign(n, SemanticClass::Static);
  for (int i = 0; i < n; ++i) {
    const std::string key = "class" + std::to_string(i);
    const std::optional<std::string> text = value(key);
    if (!text || text->empty()) {
      if (!hasDefault) throw params::ParamError(section, key, std::nullopt, "missing (and no 'default' group given)");
      classNames[i] = key;
      groups[i] = defaultGroup;
      continue;
    }
    // "<name words...> <group>": the last word is the group, the rest (may contain spaces) the name.
    const auto lastSpace = text->find_last_of(" \t");
    if (lastSpace == std::string::npos)
      throw params::ParamError(section, key, *text, "expected '<name> <group>' (group static, dynamic or invalid)");
    std::string className = text->substr(0, lastSpace);
    className.erase(className.find_last_not_of(" \t") + 1);
    classNames[i] = className;
    groups[i] = group(key, *text, text->substr(lastSpace + 1));
  }
  check();
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
