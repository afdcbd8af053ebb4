#include "pslam/core/Params.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>

#include <mrpt/config/CConfigFileMemory.h>
#include <optional>

namespace pslam::params {

namespace {

std::string lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

std::string trim(const std::string& s) {
  const auto b = s.find_first_not_of(" \t\r\n");
  if (b == std::string::npos) return "";
  const auto e = s.find_last_not_of(" \t\r\n");
  return s.substr(b, e - b + 1);
}

bool equalsIgnoreCase(const std::string& a, const std::string& b) { return lower(a) == lower(b); }

// Levenshtein distance, 2 per edit, 1 for a substitution that only changes case.
int distance(const std::string& a, const std::string& b) {
  std::vector<int> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = static_cast<int>(2 * j);
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = static_cast<int>(2 * i);
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const char x = a[i - 1], y = b[j - 1];
      const int sub = x == y ? 0 : (std::tolower(static_cast<unsigned char>(x)) ==
                                            std::tolower(static_cast<unsigned char>(y))
                                        ? 1
                                        : 2);
      cur[j] = std::min({prev[j] + 2, cur[j - 1] + 2, prev[j - 1] + sub});
    }
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

std::string didYouMean(const std::string& word, const std::vector<std::string>& candidates) {
  const std::string best = closest(word, candidates);
  return best.empty() ? "" : " (did you mean " + best + "?)";
}

// A number must use all of the text; from_chars takes no leading '+', so skip one.
const char* numberStart(const std::string& text) {
  const char* b = text.c_str();
  if (*b == '+' && text.size() > 1 && text[1] != '-') ++b;
  return b;
}

// Whole bounds in plain digits (1000000, not the shortest round-trip form 1e+06).
std::string bound(double v) {
  if (std::abs(v) < 1e15 && v == std::floor(v)) return std::to_string(static_cast<long long>(v));
  return formatDouble(v);
}

}  // namespace

// ------------------------------------------------------------------------------------------ errors
namespace {
std::string message(const std::string& section, const std::string& key, const std::optional<std::string>& value,
                    const std::string& reason) {
  std::string m = "[" + section + "]";
  if (!key.empty()) m += " " + key;
  if (value) m += " = " + *value;
  return m + ": " + reason;
}
}  // namespace

ParamError::ParamError(std::string section, std::string key, std::optional<std::string> value,
                       const std::string& reason)
    : Error(message(section, key, value, reason)), section_(std::move(section)), key_(std::move(key)) {}

ParamError::ParamError(const ParamError& e, const std::string& context)
    : Error(context + ": " + e.what()), section_(e.section_), key_(e.key_) {}

// ------------------------------------------------------------------------------------------ text
std::string valueText(const std::string& raw) {
  std::size_t cut = raw.size();
  for (std::size_t i = 0; i < raw.size(); ++i) {
    const bool atWordStart = i == 0 || std::isspace(static_cast<unsigned char>(raw[i - 1]));
    if (!atWordStart) continue;
    if (raw[i] == ';' || raw[i] == '#' || raw.compare(i, 2, "//") == 0) {
      cut = i;
      break;
    }
  }
  return trim(raw.substr(0, cut));
}

std::string closest(const std::string& word, const std::vector<std::string>& candidates) {
  // A key the word begins (a shortened key: distortion -> distortion_model) before the nearest by edit distance.
  std::string prefixed;
  for (const auto& c : candidates)
    if (c.size() > word.size() && !word.empty() && equalsIgnoreCase(c.substr(0, word.size()), word) &&
        (prefixed.empty() || c.size() < prefixed.size()))
      prefixed = c;
  if (!prefixed.empty()) return prefixed;
  std::string best;
  int bestDistance = std::numeric_limits<int>::max();
  for (const auto& c : candidates) {
    const int d = distance(word, c);
    if (d < bestDistance) {
      bestDistance = d;
      best = c;
    }
  }
  return best;
}

std::string formatDouble(double v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

std::string formatFloat(float v) {
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  const auto r = std::to_chars(buf, buf + sizeof buf, v);
  return std::string(buf, r.ptr);
}

namespace detail {

std::optional<std::string> parseSigned(const std::string& text, long long lo, long long hi, long long& out) {
  const char* b = numberStart(text);
  const char* e = text.c_str() + text.size();
  long long v = 0;
  const auto r = std::from_chars(b, e, v);
  const std::string range = "[" + std::to_string(lo) + ", " + std::to_string(hi) + "]";
  if (r.ec == std::errc::result_out_of_range) return "integer out of range " + range;
  if (text.empty() || r.ec != std::errc() || r.ptr != e) return "not an integer";
  if (v < lo || v > hi) return "integer out of range " + range;
  out = v;
  return std::nullopt;
}

std::optional<std::string> parseUnsigned(const std::string& text, unsigned long long hi, unsigned long long& out) {
  const std::string range = "[0, " + std::to_string(hi) + "]";
  if (!text.empty() && text[0] == '-') {
    long long v = 0;
    if (parseSigned(text, std::numeric_limits<long long>::min(), 0, v)) return "not an integer";
    if (v < 0) return "integer out of range " + range;
    out = 0;  // "-0"
    return std::nullopt;
  }
  const char* b = numberStart(text);
  const char* e = text.c_str() + text.size();
  unsigned long long v = 0;
  const auto r = std::from_chars(b, e, v);
  if (r.ec == std::errc::result_out_of_range) return "integer out of range " + range;
  if (text.empty() || r.ec != std::errc() || r.ptr != e) return "not an integer";
  if (v > hi) return "integer out of range " + range;
  out = v;
  return std::nullopt;
}

std::optional<std::string> parseDouble(const std::string& text, double& out) {
  const char* b = numberStart(text);
  const char* e = text.c_str() + text.size();
  double v = 0;
  const auto r = std::from_chars(b, e, v);
  if (r.ec == std::errc::result_out_of_range) return "number out of the range of double";
  if (text.empty() || r.ec != std::errc() || r.ptr != e || std::isnan(v)) return "not a number";
  out = v;
  return std::nullopt;
}

std::optional<std::string> parseFloat(const std::string& text, float& out) {
  // Parsed as a double, then rounded to float: the value MRPT's read_float (atof) gave.
  double v = 0;
  if (auto why = parseDouble(text, v)) return why;
  if (std::isfinite(v) && std::abs(v) > static_cast<double>(std::numeric_limits<float>::max()))
    return "number out of the range of float";
  out = static_cast<float>(v);
  return std::nullopt;
}

std::optional<std::string> parseBool(const std::string& text, bool& out) {
  const std::string t = lower(text);
  if (t == "true" || t == "yes" || t == "on" || t == "1") {
    out = true;
    return std::nullopt;
  }
  if (t == "false" || t == "no" || t == "off" || t == "0") {
    out = false;
    return std::nullopt;
  }
  return "not a bool (true or false)";
}

std::optional<std::size_t> findName(const std::string& text, const std::vector<std::string>& names) {
  for (std::size_t i = 0; i < names.size(); ++i)
    if (equalsIgnoreCase(text, names[i])) return i;
  return std::nullopt;
}

std::string oneOfText(const std::vector<std::string>& names) {
  std::string s = "must be one of ";
  for (std::size_t i = 0; i < names.size(); ++i) s += (i ? ", " : "") + names[i];
  return s;
}

std::optional<std::string> parseDoubleList(const std::string& text, std::vector<double>& out) {
  std::string t = trim(text);
  if (!t.empty() && t.front() == '[') {
    if (t.back() != ']') return "unbalanced '[' (expected numbers separated by commas or spaces)";
    t = t.substr(1, t.size() - 2);
  }
  for (char& c : t)
    if (c == ',') c = ' ';
  std::vector<double> values;
  std::istringstream words(t);
  std::string word;
  while (words >> word) {
    double v = 0;
    if (auto why = parseDouble(word, v)) return "'" + word + "': " + *why + " (expected numbers separated by commas or spaces)";
    values.push_back(v);
  }
  out = std::move(values);
  return std::nullopt;
}

std::string formatDoubleList(const double* v, std::size_t n) {
  std::string s;
  for (std::size_t i = 0; i < n; ++i) s += (i ? " " : "") + formatDouble(v[i]);
  return s;
}

std::vector<std::string> KeyCollector::keys() const {
  std::vector<std::string> k;
  for (const auto& r : rows_) k.push_back(r.key);
  return k;
}

void KeyCollector::add(FieldInfo row) {
  for (const auto& r : rows_)
    if (r.key == row.key) throw std::logic_error("parameter key '" + row.key + "' is listed twice in one section");
  rows_.push_back(std::move(row));
}

std::map<std::string, std::string> readSection(const mrpt::config::CConfigFileBase& cfg, const std::string& section,
                                               const std::vector<std::string>& known) {
  std::map<std::string, std::string> present;
  // MRPT matches section and key names without regard to case: insist on the exact spelling.
  std::vector<std::string> sections;
  cfg.getAllSections(sections);
  bool found = false;
  for (const auto& s : sections) {
    if (s == section) found = true;
    else if (equalsIgnoreCase(s, section))
      throw ParamError(s, "", std::nullopt, "unknown section (did you mean " + section + "?)");
  }
  if (!found) return present;
  std::vector<std::string> keys;
  cfg.getAllKeys(section, keys);
  for (const auto& k : keys) {
    if (std::find(known.begin(), known.end(), k) == known.end())
      throw ParamError(section, k, std::nullopt, "unknown key" + didYouMean(k, known));
    present[k] = valueText(cfg.read_string(section, k, ""));
  }
  return present;
}

}  // namespace detail

// ------------------------------------------------------------------------------------------ rules
Range::Range(double lo, bool loOpen, double hi, bool hiOpen) : lo_(lo), hi_(hi), loOpen_(loOpen), hiOpen_(hiOpen) {}

Range Range::orInfinite() const {
  Range r = *this;
  r.infinite_ = true;
  return r;
}

std::string Range::text() const {
  const bool hasLo = std::isfinite(lo_), hasHi = std::isfinite(hi_);
  std::string t;
  if (hasLo && hasHi)
    t = std::string("must be in ") + (loOpen_ ? "(" : "[") + bound(lo_) + ", " + bound(hi_) + (hiOpen_ ? ")" : "]");
  else if (hasLo)
    t = std::string("must be ") + (loOpen_ ? "> " : ">= ") + bound(lo_);
  else if (hasHi)
    t = std::string("must be ") + (hiOpen_ ? "< " : "<= ") + bound(hi_);
  else
    return infinite_ ? "must be a number" : "must be finite";
  return infinite_ ? t + " (inf allowed)" : t;
}

std::optional<std::string> Range::check(double v, bool floating) const {
  if (std::isnan(v)) return "must be a number";
  if (floating && std::isinf(v) && !infinite_) return "must be finite";
  // An infinite bound means "unbounded on that side".
  const bool aboveLo = std::isinf(lo_) || (loOpen_ ? v > lo_ : v >= lo_);
  const bool belowHi = std::isinf(hi_) || (hiOpen_ ? v < hi_ : v <= hi_);
  if (aboveLo && belowHi) return std::nullopt;
  return text();
}

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();
}
Range atLeast(double lo) { return Range(lo, false, kInf, true); }
Range greaterThan(double lo) { return Range(lo, true, kInf, true); }
Range inClosed(double lo, double hi) { return Range(lo, false, hi, false); }
Range inOpen(double lo, double hi) { return Range(lo, true, hi, true); }
Range inLeftOpen(double lo, double hi) { return Range(lo, true, hi, false); }
Range inRightOpen(double lo, double hi) { return Range(lo, false, hi, true); }
Range finite() { return Range(-kInf, true, kInf, true); }

OneOf oneOf(std::vector<std::string> names) { return OneOf{std::move(names)}; }

std::optional<std::string> OneOf::operator()(const std::string& v) const {
  if (std::find(names.begin(), names.end(), v) != names.end()) return std::nullopt;
  return text();
}

std::optional<std::string> NonEmpty::operator()(const std::string& v) const {
  if (!v.empty()) return std::nullopt;
  return text();
}

// ------------------------------------------------------------------------------------------ operations
std::string iniText(const std::function<void(mrpt::config::CConfigFileBase&)>& write) {
  mrpt::config::CConfigFileMemory mem;
  write(mem);
  std::string text;
  mem.getContent(text);
  return text;
}

std::map<std::string, std::string> sectionValues(const mrpt::config::CConfigFileBase& cfg, const std::string& section,
                                                 const std::vector<std::string>& known) {
  return detail::readSection(cfg, section, known);
}

void requireKnownSections(const mrpt::config::CConfigFileBase& cfg, const std::vector<std::string>& known) {
  std::vector<std::string> sections;
  cfg.getAllSections(sections);
  for (const auto& s : sections)
    if (std::find(known.begin(), known.end(), s) == known.end())
      throw ParamError(s, "", std::nullopt, "unknown section" + didYouMean(s, known));
}

// ------------------------------------------------------------------------------------------ files, overrides
namespace {
/// The file named by the `include = <file>` line before the first section (checkIniSyntax allows no other key
/// there), and the text without that line.
std::optional<std::string> takeInclude(std::string& text) {
  std::size_t begin = 0;
  while (begin < text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    const std::string line = valueText(text.substr(begin, end - begin));
    if (!line.empty() && line[0] == '[') return std::nullopt;  // sections have started
    const auto eq = line.find('=');
    if (eq != std::string::npos && lower(trim(line.substr(0, eq))) == "include") {
      const std::string file = trim(line.substr(eq + 1));
      text.erase(begin, std::min(end + 1, text.size()) - begin);
      return file;
    }
    begin = end + 1;
  }
  return std::nullopt;
}

/// readConfigText with the chain of files that include this one (cycles are errors).
std::string readConfigTextIncluding(const std::string& path, std::vector<std::filesystem::path>& chain) {
  require(std::filesystem::is_regular_file(path), path, "config file not found");
  std::ifstream in(path);
  std::stringstream stream;
  stream << in.rdbuf();
  require(static_cast<bool>(in) || in.eof(), path, "cannot read config file");
  std::string text = stream.str();
  checkIniSyntax(text, path);
  const std::optional<std::string> include = takeInclude(text);
  if (!include) return text;
  // The base file first, relative to this one; this file's keys replace the base's, key by key.
  require(!include->empty(), path, "include: no file named");
  std::filesystem::path base = *include;
  if (base.is_relative()) base = std::filesystem::path(path).parent_path() / base;
  const std::filesystem::path self = std::filesystem::weakly_canonical(path);
  chain.push_back(self);
  const std::filesystem::path baseCanonical = std::filesystem::weakly_canonical(base);
  for (const auto& f : chain)
    if (f == baseCanonical) throw Error(path + ": include = " + *include + ": the files include each other");
  std::string baseText;
  try {
    baseText = readConfigTextIncluding(base.string(), chain);
  } catch (const Error& e) {
    throw Error(path + ": include = " + *include + ": " + e.what());
  }
  chain.pop_back();
  mrpt::config::CConfigFileMemory merged(baseText), own(text);
  std::vector<std::string> sections;
  own.getAllSections(sections);
  for (const std::string& section : sections) {
    std::vector<std::string> keys;
    own.getAllKeys(section, keys);
    for (const std::string& key : keys) merged.write(section, key, own.read_string(section, key, ""));
  }
  std::string out;
  merged.getContent(out);
  return out;
}
}  // namespace

std::string readConfigText(const std::string& path) {
  std::vector<std::filesystem::path> chain;
  return readConfigTextIncluding(path, chain);
}

void checkIniSyntax(const std::string& text, const std::string& source) {
  struct Seen {
    std::string name;
    std::size_t line;
  };
  std::map<std::string, Seen> sections;                        // by lower-case name
  std::map<std::string, std::map<std::string, Seen>> keys;     // section -> lower-case key -> first line
  std::string section;
  bool inSection = false, includeSeen = false;
  std::size_t lineNo = 0, begin = 0;
  while (begin <= text.size()) {
    std::size_t end = text.find('\n', begin);
    if (end == std::string::npos) end = text.size();
    const std::string raw = text.substr(begin, end - begin);
    begin = end + 1;
    ++lineNo;
    const std::string at = source + ":" + std::to_string(lineNo) + ": ";
    if (raw.find('\0') != std::string::npos) throw Error(at + "NUL byte (not a text file?)");
    const std::string line = valueText(raw);  // without comment, trimmed
    if (line.empty() || line.compare(0, 2, "//") == 0) continue;
    if (line[0] == '@')
      throw Error(at + "'" + line + "': MRPT preprocessor lines (@define, @include) are not supported");
    if (line[0] == '[') {
      const std::string name = line.size() >= 2 && line.back() == ']' ? trim(line.substr(1, line.size() - 2)) : "";
      if (name.empty() || name.find_first_of("[]") != std::string::npos)
        throw Error(at + "'" + line + "': malformed section header (expected [Section])");
      const auto [it, isNew] = sections.emplace(lower(name), Seen{name, lineNo});
      if (!isNew)
        throw Error(at + "[" + name + "]: section appears twice (first as [" + it->second.name + "] on line " +
                    std::to_string(it->second.line) + ")");
      section = name;
      inSection = true;
      continue;
    }
    const auto eq = line.find('=');
    if (eq == std::string::npos)
      throw Error(at + "'" + line + "': expected key = value" + (inSection ? " in [" + section + "]" : ""));
    const std::string key = trim(line.substr(0, eq));
    if (key.empty()) throw Error(at + "'" + line + "': empty key" + (inSection ? " in [" + section + "]" : ""));
    if (!inSection && lower(key) == "include" && !includeSeen) {  // `include = <file>` (readConfigText)
      includeSeen = true;
      continue;
    }
    if (!inSection)
      throw Error(at + key + ": key outside any section (the file needs a [Section] header before it)");
    const std::string value = line.substr(eq + 1);
    if (value.find("${") != std::string::npos || value.find("$env{") != std::string::npos ||
        value.find("$eval{") != std::string::npos)
      throw Error(at + "[" + section + "] " + key + ": variable expansion ($...{...}) is not supported");
    auto& inThis = keys[lower(section)];
    const auto [it, isNew] = inThis.emplace(lower(key), Seen{key, lineNo});
    if (!isNew)
      throw Error(at + "[" + section + "] " + key + ": key appears twice in the section (first as " + it->second.name +
                  " on line " + std::to_string(it->second.line) + ")");
  }
}

Override parseOverride(const std::string& text) {
  auto fail = [&](const std::string& why) { throw Error("override '" + text + "': " + why); };
  const auto eq = text.find('=');
  if (eq == std::string::npos) fail("expected Section.key=value (no '=')");
  const std::string lhs = text.substr(0, eq);
  const auto dot = lhs.find('.');
  if (dot == std::string::npos) fail("expected Section.key=value (no '.' between section and key)");
  Override o{text, trim(lhs.substr(0, dot)), trim(lhs.substr(dot + 1)), trim(text.substr(eq + 1))};
  if (o.section.empty()) fail("empty section");
  if (o.key.empty()) fail("empty key");
  return o;
}

void applyOverrides(mrpt::config::CConfigFileMemory& cfg, const std::vector<std::string>& overrides) {
  for (const auto& text : overrides) {
    const Override o = parseOverride(text);
    std::vector<std::string> sections;
    cfg.getAllSections(sections);
    for (const auto& s : sections) {
      if (s != o.section && equalsIgnoreCase(s, o.section))
        throw Error("override '" + text + "': section differs only in case from [" + s + "]");
      if (s != o.section) continue;
      std::vector<std::string> keys;
      cfg.getAllKeys(s, keys);
      for (const auto& k : keys)
        if (k != o.key && equalsIgnoreCase(k, o.key))
          throw Error("override '" + text + "': key differs only in case from " + k + " in [" + s + "]");
    }
    cfg.write(o.section, o.key, o.value);
  }
}

void loadConfigFile(const std::string& path, const std::vector<std::string>& sections,
                    const std::function<void(const mrpt::config::CConfigFileBase&)>& load,
                    const std::vector<std::string>& overrides) {
  const std::string text = readConfigText(path);
  std::unique_ptr<mrpt::config::CConfigFileMemory> cfg;
  try {
    cfg = std::make_unique<mrpt::config::CConfigFileMemory>(text);
  } catch (const std::exception& e) {
    // checkIniSyntax() leaves MRPT's reader nothing to fail on; should it still, keep its first line.
    const std::string what = e.what();
    throw Error(path + ": cannot parse the ini file: " + what.substr(0, what.find('\n')));
  }
  applyOverrides(*cfg, overrides);
  withSource(path, overrides, [&] {
    if (!sections.empty()) requireKnownSections(*cfg, sections);
    load(*cfg);
  });
}

void withSource(const std::string& path, const std::vector<std::string>& overrides, const std::function<void()>& load) {
  try {
    load();
  } catch (const ParamError& e) {
    // The last override of a key is the one in effect.
    for (auto it = overrides.rbegin(); it != overrides.rend(); ++it) {
      const Override o = parseOverride(*it);
      if (o.section == e.section() && (e.key().empty() || o.key == e.key()))
        throw ParamError(e, "override '" + *it + "'");
    }
    throw ParamError(e, path);
  } catch (const Error& e) {
    throw Error(path + ": " + e.what());
  }
}

}  // namespace pslam::params
