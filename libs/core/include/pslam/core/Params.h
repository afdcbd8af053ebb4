#pragma once
// One declarative parameter mechanism (doc/architecture.md, "Configuration", doc/conventions.md "Parameters").
//
// A parameter struct lists its fields once, in visitFields(): key, member, rule, one-line doc.
//
//   struct OrbParams {
//     int nFeatures = 2000;
//     double scaleFactor = 1.2;
//     template <class V> void visitFields(V& v) {
//       using namespace pslam::params;
//       PSLAM_FIELD(v, nFeatures, atLeast(1), "target number of keypoints over all levels");
//       PSLAM_FIELD(v, scaleFactor, inOpen(1, 4), "scale between consecutive pyramid levels");
//     }
//     PSLAM_PARAMS("ORB")
//   };
//   PSLAM_DEFINE_PARAMS(OrbParams)   // in one .cpp
//
// PSLAM_PARAMS(section) + PSLAM_DEFINE_PARAMS(Type) add, all driven by that one list:
//   loadFromConfigFile(cfg, section = "ORB")  strict parsing of the keys present (absent keys keep their
//                                             value), unknown keys rejected naming the closest valid key,
//                                             then check();
//   saveToConfigFile(cfg, section = "ORB")    every key; the text reloads to equal values (shortest
//                                             round-trip formatting of doubles and floats);
//   check()                                   every rule, in list order.
//
// Keys. The key of a field is its C++ name (PSLAM_FIELD stringifies the member); PSLAM_KEY(v, "key", member,
// rule, doc) gives another key (the tools' options: `max_time_difference` for association.maxTimeDifference).
// Nested structs:
//   v.flat(sub)              the fields of `sub` are keys of the same section under their own names;
//   PSLAM_NESTED(v, sub)     ... under `sub.<field>`: used when leaf names of two nested structs would collide
//                            ([Tracking] keyFrames.minInliers and pnp.minInliers); every struct in the
//                            collision is prefixed, never only one of them;
//   v.fromSection("S", sub)  `sub` is not read or written with this section (the caller copies it from
//                            section [S]); check() checks it under [S].
// A duplicate key in one section is a programming error (std::logic_error on load).
//
// Values. Text after whitespace + `;`, `#` or `//` is a comment. int/unsigned/size_t/...: a whole decimal
// number inside the range of the C++ type; double/float: a decimal number or inf/-inf (never nan); bool:
// true/false, yes/no, on/off, 1/0; enums: one of their names (enumNames() found by argument-dependent lookup,
// case-insensitive); std::string and std::filesystem::path: the text; std::vector<double> and
// std::array<double, N>: numbers separated by commas or spaces (an array exactly N).
//
// Errors are ParamError, one format:  `[Section] key = value: reason`  (e.g. `[Tracking] minPoseInliers = 1:
// must be >= 3`), `[Section] key: unknown key (did you mean maxLocalKeyFrames?)`, `[Sectoin]: unknown section
// (did you mean Section?)`.
//
// Files. loadConfigFile() (or loadSectionsFromFile() / loadSectionFromFile()) is how every tool reads its ini:
// readConfigText() checks the file's structure (checkIniSyntax(): keys outside a section, lines that are not
// `key = value`, a key or section given twice are errors `<file>:<line>: ...`) and resolves `include = <file>`
// (one line before the first section; the named file, relative to this one, is read first and this file's keys
// replace its keys one by one), applyOverrides() applies
// `Section.key=value` texts, unknown sections are rejected, and withSource() puts the file name (or the override
// text) in front of every error: `config/slam/kitti.ini: [Tracking] ...`. Command-line numbers are checked with
// the same parsing and rules by cliCheck() (CLI11 Option::check).
#include <cmath>
#include <array>
#include <cstdint>
#include <algorithm>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <optional>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

#include <mrpt/config/CConfigFileBase.h>

#include "pslam/core/Error.h"

namespace mrpt::config {
class CConfigFileMemory;
}

namespace pslam::params {

/// `[Section] key = value: reason`; without the value for an unknown key, without the key for a section error.
class ParamError : public Error {
 public:
  ParamError(std::string section, std::string key, std::optional<std::string> value, const std::string& reason);
  /// The same error with `context: ` in front (a file name, an override).
  ParamError(const ParamError& e, const std::string& context);
  const std::string& section() const { return section_; }
  const std::string& key() const { return key_; }

 private:
  std::string section_, key_;
};

// ------------------------------------------------------------------------------------------ value codecs
/// The value of an ini line: up to a comment (`;`, `#` or `//` at the start or after whitespace), trimmed.
std::string valueText(const std::string& raw);
/// The closest of `candidates` to `word` (edit distance, case differences counting least); "" if none.
std::string closest(const std::string& word, const std::vector<std::string>& candidates);
std::string formatDouble(double v);
std::string formatFloat(float v);

namespace detail {
std::optional<std::string> parseSigned(const std::string& text, long long lo, long long hi, long long& out);
std::optional<std::string> parseUnsigned(const std::string& text, unsigned long long hi, unsigned long long& out);
std::optional<std::string> parseDouble(const std::string& text, double& out);
std::optional<std::string> parseFloat(const std::string& text, float& out);
std::optional<std::string> parseBool(const std::string& text, bool& out);
std::optional<std::size_t> findName(const std::string& text, const std::vector<std::string>& names);
std::string oneOfText(const std::vector<std::string>& names);
/// Numbers separated by commas and/or whitespace, optionally in one pair of brackets ("1, 2", "[1 2]", "").
std::optional<std::string> parseDoubleList(const std::string& text, std::vector<double>& out);
std::string formatDoubleList(const double* v, std::size_t n);
}  // namespace detail

/// Text <-> value; parse() returns the reason when the text is not a valid value.
template <class T, class Enable = void>
struct Codec;

template <class T>
struct Codec<T, std::enable_if_t<std::is_integral_v<T> && !std::is_same_v<T, bool>>> {
  static std::optional<std::string> parse(const std::string& text, T& out) {
    if constexpr (std::is_signed_v<T>) {
      long long v = 0;
      auto why = detail::parseSigned(text, std::numeric_limits<T>::min(), std::numeric_limits<T>::max(), v);
      if (!why) out = static_cast<T>(v);
      return why;
    } else {
      unsigned long long v = 0;
      auto why = detail::parseUnsigned(text, std::numeric_limits<T>::max(), v);
      if (!why) out = static_cast<T>(v);
      return why;
    }
  }
  static std::string format(T v) { return std::to_string(v); }
};

template <>
struct Codec<double> {
  static std::optional<std::string> parse(const std::string& text, double& out) { return detail::parseDouble(text, out); }
  static std::string format(double v) { return formatDouble(v); }
};

template <>
struct Codec<float> {
  static std::optional<std::string> parse(const std::string& text, float& out) { return detail::parseFloat(text, out); }
  static std::string format(float v) { return formatFloat(v); }
};

template <>
struct Codec<bool> {
  static std::optional<std::string> parse(const std::string& text, bool& out) { return detail::parseBool(text, out); }
  static std::string format(bool v) { return v ? "true" : "false"; }
};

template <>
struct Codec<std::string> {
  static std::optional<std::string> parse(const std::string& text, std::string& out) {
    out = text;
    return std::nullopt;
  }
  static std::string format(const std::string& v) { return v; }
};

template <>
struct Codec<std::filesystem::path> {
  static std::optional<std::string> parse(const std::string& text, std::filesystem::path& out) {
    out = text;
    return std::nullopt;
  }
  static std::string format(const std::filesystem::path& v) { return v.string(); }
};

/// A list of numbers: `1, 2, 3` or `1 2 3` (optionally in brackets); written space-separated.
template <>
struct Codec<std::vector<double>> {
  static std::optional<std::string> parse(const std::string& text, std::vector<double>& out) {
    return detail::parseDoubleList(text, out);
  }
  static std::string format(const std::vector<double>& v) { return detail::formatDoubleList(v.data(), v.size()); }
};

/// Exactly N numbers, as for std::vector<double>.
template <std::size_t N>
struct Codec<std::array<double, N>> {
  static std::optional<std::string> parse(const std::string& text, std::array<double, N>& out) {
    std::vector<double> v;
    if (auto why = detail::parseDoubleList(text, v)) return why;
    if (v.size() != N) return "expected " + std::to_string(N) + " numbers, got " + std::to_string(v.size());
    std::copy(v.begin(), v.end(), out.begin());
    return std::nullopt;
  }
  static std::string format(const std::array<double, N>& v) { return detail::formatDoubleList(v.data(), N); }
};

/// Enums: `enumNames(E{})`, found by argument-dependent lookup, returns a sequence of {value, name} pairs.
template <class E>
struct Codec<E, std::enable_if_t<std::is_enum_v<E>>> {
  static std::optional<std::string> parse(const std::string& text, E& out) {
    std::vector<std::string> names;
    for (const auto& [value, name] : enumNames(E{})) names.emplace_back(name);
    const auto i = detail::findName(text, names);
    if (!i) return detail::oneOfText(names);
    out = std::begin(enumNames(E{}))[*i].first;
    return std::nullopt;
  }
  static std::string format(E v) {
    for (const auto& [value, name] : enumNames(E{}))
      if (value == v) return name;
    return "?";
  }
};

/// The name of an enum value (its enumNames() entry) and the value of a name (throws pslam::Error listing the
/// valid names).
template <class E>
std::string enumName(E v) {
  return Codec<E>::format(v);
}
template <class E>
E parseEnum(const std::string& text, const std::string& what) {
  E v{};
  if (auto why = Codec<E>::parse(valueText(text), v)) throw Error(what + " '" + text + "': " + *why);
  return v;
}

// ------------------------------------------------------------------------------------------ rules
// A rule maps a value to the reason it is invalid (nullopt = valid); text() describes it.

struct AnyValue {
  template <class T>
  std::optional<std::string> operator()(const T&) const {
    return std::nullopt;
  }
  std::string text() const { return ""; }
};
inline constexpr AnyValue anyValue{};

/// A numeric interval. Non-finite values fail ("must be finite") unless orInfinite().
class Range {
 public:
  Range(double lo, bool loOpen, double hi, bool hiOpen);
  /// +inf / -inf also pass when they lie in the interval (e.g. Table 3.1's B = inf).
  Range orInfinite() const;
  template <class T>
  std::optional<std::string> operator()(const T& v) const {
    return check(static_cast<double>(v), std::is_floating_point_v<T>);
  }
  std::string text() const;

 private:
  std::optional<std::string> check(double v, bool floating) const;
  double lo_, hi_;
  bool loOpen_, hiOpen_, infinite_ = false;
};
Range atLeast(double lo);
Range greaterThan(double lo);
Range inClosed(double lo, double hi);     ///< [lo, hi]
Range inOpen(double lo, double hi);       ///< (lo, hi)
Range inLeftOpen(double lo, double hi);   ///< (lo, hi]
Range inRightOpen(double lo, double hi);  ///< [lo, hi)
Range finite();                           ///< any finite number

/// Any predicate; `reason` is the message when it fails (e.g. "must be in (0, iniThFAST]").
template <class F>
struct Satisfies {
  F pred;
  std::string reason;
  template <class T>
  std::optional<std::string> operator()(const T& v) const {
    if (pred(v)) return std::nullopt;
    return reason;
  }
  std::string text() const { return reason; }
};
template <class F>
Satisfies<F> satisfies(F pred, std::string reason) {
  return {std::move(pred), std::move(reason)};
}

/// A rule with its own reasons: `check(v)` returns the reason `v` is invalid (nullopt = valid); `text` describes
/// the rule (describe()). For values whose checks have several reasons (a list: its length and its numbers).
template <class F>
struct Custom {
  F check;
  std::string description;
  template <class T>
  std::optional<std::string> operator()(const T& v) const {
    return check(v);
  }
  std::string text() const { return description; }
};
template <class F>
Custom<F> custom(F check, std::string description) {
  return {std::move(check), std::move(description)};
}

/// A string among `names` (exact).
struct OneOf {
  std::vector<std::string> names;
  std::optional<std::string> operator()(const std::string& v) const;
  std::string text() const { return detail::oneOfText(names); }
};
OneOf oneOf(std::vector<std::string> names);

struct NonEmpty {
  std::optional<std::string> operator()(const std::string& v) const;
  std::string text() const { return "must not be empty"; }
};
inline constexpr NonEmpty nonEmpty{};

// ------------------------------------------------------------------------------------------ visitors
/// One row of describe(): a key, its current value, its rule and its doc.
struct FieldInfo {
  std::string key, value, rule, doc;
};

namespace detail {

/// What every visitor does with groups: flat() recurses, nested() puts `name.` in front of the keys,
/// fromSection() skips the struct (Checker checks it under its own section).
template <class Derived>
class Visitor {
 public:
  template <class S>
  void flat(S& sub) {
    sub.visitFields(self());
  }
  template <class S>
  void nested(const char* name, S& sub) {
    const std::string saved = prefix_;
    prefix_ += std::string(name) + ".";
    sub.visitFields(self());
    prefix_ = saved;
  }
  template <class S>
  void fromSection(const char*, S&) {}

 protected:
  std::string key(const char* name) const { return prefix_ + name; }

 private:
  Derived& self() { return static_cast<Derived&>(*this); }
  std::string prefix_;
};

/// Collects the keys (and their rows for describe()); a duplicate key is a programming error.
class KeyCollector : public Visitor<KeyCollector> {
 public:
  template <class T, class R>
  void field(const char* name, T& value, const R& rule, const char* doc) {
    add({key(name), Codec<T>::format(value), rule.text(), doc});
  }
  const std::vector<FieldInfo>& rows() const { return rows_; }
  std::vector<std::string> keys() const;

 private:
  void add(FieldInfo row);
  std::vector<FieldInfo> rows_;
};

/// The text of every key of `section` present in `cfg`, by key; throws ParamError for an unknown key (naming
/// the closest of `known`) or a section name that differs from `section` only in case.
std::map<std::string, std::string> readSection(const mrpt::config::CConfigFileBase& cfg, const std::string& section,
                                               const std::vector<std::string>& known);

class Loader : public Visitor<Loader> {
 public:
  Loader(const std::map<std::string, std::string>& present, const std::string& section)
      : present_(present), section_(section) {}
  template <class T, class R>
  void field(const char* name, T& value, const R&, const char*) {
    const std::string k = key(name);
    const auto it = present_.find(k);
    if (it == present_.end()) return;
    T parsed = value;
    if (auto why = Codec<T>::parse(it->second, parsed)) throw ParamError(section_, k, it->second, *why);
    value = parsed;
  }

 private:
  const std::map<std::string, std::string>& present_;
  const std::string& section_;
};

class Saver : public Visitor<Saver> {
 public:
  Saver(mrpt::config::CConfigFileBase& cfg, const std::string& section) : cfg_(cfg), section_(section) {}
  template <class T, class R>
  void field(const char* name, T& value, const R&, const char*) {
    cfg_.write(section_, key(name), Codec<T>::format(value));
  }

 private:
  mrpt::config::CConfigFileBase& cfg_;
  const std::string& section_;
};

class Checker : public Visitor<Checker> {
 public:
  explicit Checker(const std::string& section) : section_(section) {}
  template <class T, class R>
  void field(const char* name, T& value, const R& rule, const char*) {
    if (auto why = rule(value)) throw ParamError(section_, key(name), Codec<T>::format(value), *why);
  }
  template <class S>
  void fromSection(const char* section, S& sub) {
    const std::string s = section;
    Checker other(s);
    sub.visitFields(other);
  }

 private:
  const std::string& section_;
};

/// Parses a text as the value of one key and applies the key's rule (cliCheckKey).
class KeyChecker : public Visitor<KeyChecker> {
 public:
  KeyChecker(const std::string& target, const std::string& text) : target_(target), text_(text) {}
  template <class T, class R>
  void field(const char* name, T& value, const R& rule, const char*) {
    if (key(name) != target_) return;
    found_ = true;
    T parsed = value;
    if (auto why = Codec<T>::parse(text_, parsed)) reason_ = *why;
    else if (auto bad = rule(parsed)) reason_ = *bad;
  }
  bool found() const { return found_; }
  const std::optional<std::string>& reason() const { return reason_; }

 private:
  const std::string& target_;
  const std::string& text_;
  bool found_ = false;
  std::optional<std::string> reason_;
};

// visitFields() is one non-const template for every visitor; saving and checking only read the fields.
template <class P>
P& mutableRef(const P& p) {
  return const_cast<P&>(p);
}

}  // namespace detail

// ------------------------------------------------------------------------------------------ operations
template <class P>
void check(const P& p, const std::string& section) {
  detail::Checker c(section);
  detail::mutableRef(p).visitFields(c);
}

template <class P>
void save(const P& p, mrpt::config::CConfigFileBase& cfg, const std::string& section) {
  detail::Saver s(cfg, section);
  detail::mutableRef(p).visitFields(s);
}

template <class P>
std::vector<FieldInfo> describe(const P& p) {
  detail::KeyCollector keys;
  detail::mutableRef(p).visitFields(keys);
  return keys.rows();
}

template <class P>
std::vector<std::string> keysOf(const P& p) {
  detail::KeyCollector keys;
  detail::mutableRef(p).visitFields(keys);
  return keys.keys();
}

template <class P>
void load(P& p, const mrpt::config::CConfigFileBase& cfg, const std::string& section) {
  const auto present = detail::readSection(cfg, section, keysOf(p));
  detail::Loader loader(present, section);
  p.visitFields(loader);
  check(p, section);
}

/// The ini text of save(p, section).
std::string iniText(const std::function<void(mrpt::config::CConfigFileBase&)>& write);
template <class P>
std::string toIniText(const P& p, const std::string& section) {
  return iniText([&](mrpt::config::CConfigFileBase& cfg) { save(p, cfg, section); });
}

// ---- a configuration of several sections (SlamParams): `template <class V> void visitSections(V& v)` with
// v.section("ORB", orb); ... Unknown sections are errors naming the closest section.

namespace detail {
struct SectionNames {
  std::vector<std::string> names;
  template <class P>
  void section(const char* name, P&) { names.emplace_back(name); }
};
struct SectionLoader {
  const mrpt::config::CConfigFileBase& cfg;
  template <class P>
  void section(const char* name, P& p) { load(p, cfg, name); }
};
struct SectionSaver {
  mrpt::config::CConfigFileBase& cfg;
  template <class P>
  void section(const char* name, P& p) { save(p, cfg, name); }
};
struct SectionChecker {
  template <class P>
  void section(const char* name, P& p) { check(p, name); }
};
/// The sections (other than `except`) that have `key`.
struct SectionsWithKey {
  std::string key, except;
  std::vector<std::string> found;
  template <class P>
  void section(const char* name, P& p) {
    if (name == except) return;
    const std::vector<std::string> keys = keysOf(p);
    if (std::find(keys.begin(), keys.end(), key) != keys.end()) found.emplace_back(name);
  }
};
}  // namespace detail

/// Throws ParamError `[Name]: unknown section (did you mean X?)` for a section of `cfg` not in `known`.
void requireKnownSections(const mrpt::config::CConfigFileBase& cfg, const std::vector<std::string>& known);

template <class C>
std::vector<std::string> sectionsOf(const C& c) {
  detail::SectionNames n;
  detail::mutableRef(c).visitSections(n);
  return n.names;
}
template <class C>
void loadSections(C& c, const mrpt::config::CConfigFileBase& cfg) {
  requireKnownSections(cfg, sectionsOf(c));
  detail::SectionLoader l{cfg};
  try {
    c.visitSections(l);
  } catch (const ParamError& e) {
    // A key of another section (e.g. one that moved there): say where it belongs.
    if (e.key().empty() || std::string(e.what()).find(": unknown key") == std::string::npos) throw;
    detail::SectionsWithKey w{e.key(), e.section(), {}};
    c.visitSections(w);
    if (w.found.empty()) throw;
    const std::string what = e.what(), prefix = "[" + e.section() + "] " + e.key() + ": ";
    const std::string reason = what.rfind(prefix, 0) == 0 ? what.substr(prefix.size()) : "unknown key";
    throw ParamError(e.section(), e.key(), std::nullopt, reason + "; [" + w.found.front() + "] has a key of this name");
  }
}
template <class C>
void saveSections(const C& c, mrpt::config::CConfigFileBase& cfg) {
  detail::SectionSaver s{cfg};
  detail::mutableRef(c).visitSections(s);
}
template <class C>
void checkSections(const C& c) {
  detail::SectionChecker k;
  detail::mutableRef(c).visitSections(k);
}

// ------------------------------------------------------------------------------------------ files, overrides
/// The text of an ini file; throws pslam::Error naming the file when it is missing or unreadable.
std::string readConfigText(const std::string& path);

/// One `Section.key=value` (split at the first '=' and the first '.' before it; parts trimmed).
struct Override {
  std::string text, section, key, value;
};
/// Throws pslam::Error `override 'text': ...` when the text has no '=', no '.', an empty section or an empty key.
Override parseOverride(const std::string& text);
/// Writes each override into `cfg` in order (a later one wins). Throws pslam::Error naming the text when it is
/// malformed or when its section or key differs only in case from one in `cfg` (MRPT matches names
/// case-insensitively, so such an override would silently change the other key). An unknown key is left to
/// the loader's unknown-key check.
void applyOverrides(mrpt::config::CConfigFileMemory& cfg, const std::vector<std::string>& overrides);

/// Runs `load` and puts the source in front of any error: `override 'S.k=v': ` when the failing key was set
/// by an override, `<path>: ` otherwise.
void withSource(const std::string& path, const std::vector<std::string>& overrides, const std::function<void()>& load);

/// Checks the structure of ini text (MRPT's reader accepts almost anything and drops what it cannot use):
/// every line is blank, a comment (`;`, `#`, `//`), a `[Section]` header, or `key = value` after a header; no
/// section and no key of one section appears twice (names compared as MRPT does, without regard to case); no
/// MRPT preprocessor line (`@define`, `@include`) and no variable expansion (`${..}`, `$env{..}`, `$eval{..}`).
/// Throws pslam::Error `<source>:<line>: ...` naming the section and key.
void checkIniSyntax(const std::string& text, const std::string& source);

/// The one way a tool reads an ini file: its text (readConfigText: missing file, syntax), `overrides` applied,
/// sections other than `sections` rejected (naming the closest; empty `sections`: any, for files of several
/// blocks of which the caller picks one, as camera ini files), then `load(cfg)`. Every error is one line that
/// names the file, or the override that set the failing key (withSource).
void loadConfigFile(const std::string& path, const std::vector<std::string>& sections,
                    const std::function<void(const mrpt::config::CConfigFileBase&)>& load,
                    const std::vector<std::string>& overrides = {});

/// A configuration of several sections (visitSections) from the file `path`.
template <class C>
void loadSectionsFromFile(C& c, const std::string& path, const std::vector<std::string>& overrides = {}) {
  loadConfigFile(path, sectionsOf(c), [&](const mrpt::config::CConfigFileBase& cfg) { loadSections(c, cfg); },
                 overrides);
}

/// One parameter struct from section `section` of the file `path`, which may hold no other section.
template <class P>
void loadSectionFromFile(P& p, const std::string& path, const std::string& section) {
  loadConfigFile(path, {section}, [&](const mrpt::config::CConfigFileBase& cfg) { p.loadFromConfigFile(cfg, section); });
}

// ---- parameters whose keys are not a fixed list (class0 ... classN of a class map)

/// The text of every key of [section] present in `cfg`, by key; throws ParamError for a key not in `known`
/// (naming the closest) or a section spelled in another case.
std::map<std::string, std::string> sectionValues(const mrpt::config::CConfigFileBase& cfg, const std::string& section,
                                                 const std::vector<std::string>& known);

/// `text` parsed as a T and checked by `rule`; throws ParamError `[section] key = text: reason`.
template <class T, class R = AnyValue>
T parseValue(const std::string& section, const std::string& key, const std::string& text, const R& rule = anyValue) {
  T v{};
  if (auto why = Codec<T>::parse(text, v)) throw ParamError(section, key, text, *why);
  if (auto why = rule(v)) throw ParamError(section, key, text, *why);
  return v;
}

// ---- command-line options

/// A check for a command-line option with the signature of CLI11's Option::check(): "" when `text` is a T by
/// the strict parsing of ini values (whole text, in the range of T, never nan) and satisfies `rule` (e.g.
/// atLeast(0): finite, >= 0), otherwise `<text>: <reason>`. Usage: `->check(params::cliCheck<double>(atLeast(0)))`.
template <class T, class R = AnyValue>
std::function<std::string(const std::string&)> cliCheck(R rule = anyValue) {
  return [rule](const std::string& text) -> std::string {
    T v{};
    if (auto why = Codec<T>::parse(text, v)) return text + ": " + *why;
    if (auto why = rule(v)) return text + ": " + *why;
    return "";
  };
}

/// The check of a command-line option that sets the key `key` of a P: that key's parsing and rule (the other
/// fields at their defaults, for rules that read them), so the option and the ini key cannot disagree; "" or
/// `<text>: <reason>`. A key P does not have is a programming error (std::logic_error when the check runs).
template <class P>
std::function<std::string(const std::string&)> cliCheckKey(std::string key) {
  return [key](const std::string& text) -> std::string {
    P p{};
    detail::KeyChecker c(key, text);
    p.visitFields(c);
    if (!c.found()) throw std::logic_error("cliCheckKey: no parameter key '" + key + "'");
    return c.reason() ? text + ": " + *c.reason() : "";
  };
}

/// The value of a command-line option checked by `rule`; throws pslam::Error `<option> = <value>: <reason>`.
template <class T, class R>
void checkOption(const std::string& option, const T& value, const R& rule) {
  if (auto why = rule(value)) throw Error(option + " = " + Codec<T>::format(value) + ": " + *why);
}

}  // namespace pslam::params

/// One field of a visitFields() list: key = the member's name.
#define PSLAM_FIELD(v, member, rule, doc) (v).field(#member, member, rule, doc)
/// A field whose key is not the member's name: the tools' options keep their snake_case keys
/// (`max_time_difference` for association.maxTimeDifference).
#define PSLAM_KEY(v, key, member, rule, doc) (v).field(key, member, rule, doc)
/// A nested struct whose keys are `member.<field>` (see Params.h: only where leaf names collide).
#define PSLAM_NESTED(v, member) (v).nested(#member, member)

/// Inside a struct with visitFields(): declares loadFromConfigFile / saveToConfigFile (default section
/// `section`) and check() (errors name `section`). PSLAM_DEFINE_PARAMS(Type) in one .cpp defines them from the
/// field list (so the visitors are instantiated once, not in every file that includes the header).
#define PSLAM_PARAMS(section)                                                                                  \
  static constexpr const char* kSection = section;                                                             \
  void loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& sectionName = kSection); \
  void saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& sectionName = kSection) const;  \
  void check() const;

#define PSLAM_DEFINE_PARAMS(Type)                                                                               \
  void Type::loadFromConfigFile(const mrpt::config::CConfigFileBase& cfg, const std::string& sectionName) {    \
    ::pslam::params::load(*this, cfg, sectionName);                                                            \
  }                                                                                                            \
  void Type::saveToConfigFile(mrpt::config::CConfigFileBase& cfg, const std::string& sectionName) const {      \
    ::pslam::params::save(*this, cfg, sectionName);                                                            \
  }                                                                                                            \
  void Type::check() const { ::pslam::params::check(*this, kSection); }
