// Seeded mutation fuzzing of the ini reader: every ini file of config/ is mutated (bit flips, byte deletions and
// insertions, duplicated / deleted / swapped lines, garbage values, truncation, headers removed or added, key
// case changed) and read by the reader of its folder, in a forked child with an alarm. Each mutant must load,
// or throw pslam::Error whose message names the file: never another exception, a signal or a hang.
#include <gtest/gtest.h>

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "pslam/core/Error.h"
#include "pslam/core/Params.h"
#include "pslam/datasets/Camera.h"
#include "pslam/landmarks/PointModel.h"
#include "pslam/manhattan/ManhattanEvalApp.h"
#include "pslam/priors/NormalPriorsApp.h"
#include "pslam/priors/SemanticClassMap.h"
#include "pslam/priors/SemanticNetwork.h"
#include "pslam/synth/SynthApp.h"
#include "pslam/system/SlamParams.h"

namespace fs = std::filesystem;
using namespace pslam;

namespace {

constexpr int kMutantsPerFile = 12;
constexpr unsigned kAlarmSeconds = 20;

// Exit codes of the child.
constexpr int kLoaded = 0, kErrorNamingFile = 10, kErrorNotNamingFile = 11, kOtherException = 12;

using Reader = std::function<void(const fs::path&)>;

// The readers of a config file, by its folder (and name), as the tools read it.
std::vector<Reader> readersFor(const fs::path& original) {
  const std::string folder = original.parent_path().filename().string();
  const std::string name = original.filename().string();
  if (folder == "slam") return {[](const fs::path& p) { system::loadSlamParams(p.string()); }};
  if (folder == "synth")
    return {[](const fs::path& p) {
      synth::SynthOptions o;
      params::loadSectionFromFile(o, p.string(), synth::SynthOptions::kSection);
    }};
  if (folder == "manhattan")
    return {[](const fs::path& p) { manhattan::ManhattanEvalConfig::loadFromFile(p); },
            [](const fs::path& p) { priors::NormalPriorsConfig::loadFromFile(p); }};
  if (folder == "cameras")
    return {[](const fs::path& p) { datasets::loadCameraIni(p); },
            [](const fs::path& p) { datasets::loadFrameRateFromIni(p); }};
  if (folder == "semantic") {
    if (name == "keypoint_model.ini")
      return {[](const fs::path& p) {
        landmarks::PointModelParams m;
        params::loadSectionFromFile(m, p.string(), landmarks::PointModelParams::kSection);
      }};
    if (name.rfind("enet", 0) == 0) return {[](const fs::path& p) { priors::SemanticNetworkParams::loadFromFile(p); }};
    return {[](const fs::path& p) { priors::SemanticClassMap::loadFromFile(p); }};
  }
  return {};
}

std::string readText(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> splitLines(const std::string& text) {
  std::vector<std::string> lines;
  std::stringstream ss(text);
  std::string l;
  while (std::getline(ss, l)) lines.push_back(l);
  return lines;
}

std::string joinLines(const std::vector<std::string>& lines) {
  std::string t;
  for (const auto& l : lines) t += l + "\n";
  return t;
}

// One mutation of `text`, drawn from `rng`; `what` says which.
std::string mutate(const std::string& text, std::mt19937& rng, std::string& what) {
  auto pick = [&](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n ? n - 1 : 0)(rng); };
  static const std::vector<std::string> garbage = {
      "",        "abc",   "nan",    "-nan",    "inf",  "-inf",   "1e999",     "-1e999",   "2000000000000",
      "-1",      "0",     "2000.7", "1 extra", "0x10", "1,5",    "true",      "maybe",    "[1 2",
      "]",       "${X}",  "$eval{1+}", "$env{HOME}", "=", "[", ";", "# c", "\x01\x02", "\xff\xfe", "9999999999999999999999",
      std::string(300, 'x')};
  static const std::vector<std::string> extraLines = {"[Bogus]", "[]", "[ORB", "key = value", "@define X 1", "=5",
                                                      "garbage line", "x = ${Y}", "\t", "[SemanticNetwork]"};
  std::vector<std::string> lines = splitLines(text);
  std::string t = text;
  switch (pick(10)) {
    case 0: {  // flip a bit
      if (t.empty()) break;
      const std::size_t i = pick(t.size());
      t[i] = static_cast<char>(t[i] ^ (1 << pick(8)));
      what = "bit flip at " + std::to_string(i);
      return t;
    }
    case 1: {  // delete bytes
      if (t.empty()) break;
      const std::size_t i = pick(t.size()), n = 1 + pick(8);
      t.erase(i, n);
      what = "delete " + std::to_string(n) + " bytes at " + std::to_string(i);
      return t;
    }
    case 2: {  // insert bytes
      const std::size_t i = pick(t.size() + 1), n = 1 + pick(4);
      std::string ins;
      for (std::size_t k = 0; k < n; ++k) ins += static_cast<char>(pick(256));
      t.insert(i, ins);
      what = "insert " + std::to_string(n) + " bytes at " + std::to_string(i);
      return t;
    }
    case 3: {  // duplicate a line
      if (lines.empty()) break;
      const std::size_t i = pick(lines.size());
      lines.insert(lines.begin() + static_cast<long>(i), lines[i]);
      what = "duplicate line " + std::to_string(i + 1);
      return joinLines(lines);
    }
    case 4: {  // delete a line
      if (lines.empty()) break;
      const std::size_t i = pick(lines.size());
      lines.erase(lines.begin() + static_cast<long>(i));
      what = "delete line " + std::to_string(i + 1);
      return joinLines(lines);
    }
    case 5: {  // a garbage value
      std::vector<std::size_t> kv;
      for (std::size_t i = 0; i < lines.size(); ++i)
        if (lines[i].find('=') != std::string::npos && lines[i][0] != '#' && lines[i][0] != ';') kv.push_back(i);
      if (kv.empty()) break;
      const std::size_t i = kv[pick(kv.size())];
      const std::string& g = garbage[pick(garbage.size())];
      lines[i] = lines[i].substr(0, lines[i].find('=') + 1) + " " + g;
      what = "value of line " + std::to_string(i + 1) + " = '" + g + "'";
      return joinLines(lines);
    }
    case 6: {  // truncate
      const std::size_t i = pick(t.size() + 1);
      what = "truncate at " + std::to_string(i);
      return t.substr(0, i);
    }
    case 7: {  // swap two lines
      if (lines.size() < 2) break;
      const std::size_t i = pick(lines.size()), j = pick(lines.size());
      std::swap(lines[i], lines[j]);
      what = "swap lines " + std::to_string(i + 1) + " and " + std::to_string(j + 1);
      return joinLines(lines);
    }
    case 8: {  // insert a line (a header, a key before any header, garbage), or remove every header
      if (pick(3) == 0) {
        lines.erase(std::remove_if(lines.begin(), lines.end(), [](const std::string& l) { return !l.empty() && l[0] == '['; }),
                    lines.end());
        what = "remove every section header";
        return joinLines(lines);
      }
      const std::size_t i = pick(lines.size() + 1);
      const std::string& l = extraLines[pick(extraLines.size())];
      lines.insert(lines.begin() + static_cast<long>(i), l);
      what = "insert line '" + l + "' at " + std::to_string(i + 1);
      return joinLines(lines);
    }
    case 9: {  // change the case of a letter of a key or a header
      std::vector<std::size_t> named;
      for (std::size_t i = 0; i < lines.size(); ++i)
        if (!lines[i].empty() && lines[i][0] != '#' && lines[i][0] != ';') named.push_back(i);
      if (named.empty()) break;
      const std::size_t i = named[pick(named.size())];
      const std::size_t end = std::min(lines[i].find('='), lines[i].size());
      const std::size_t k = pick(end);
      if (std::isalpha(static_cast<unsigned char>(lines[i][k])))
        lines[i][k] = static_cast<char>(std::islower(static_cast<unsigned char>(lines[i][k])) ? std::toupper(lines[i][k])
                                                                                               : std::tolower(lines[i][k]));
      what = "case of a letter on line " + std::to_string(i + 1);
      return joinLines(lines);
    }
  }
  what = "unchanged";
  return text;
}

// Runs `read` on `path` in a child; its exit code (kLoaded, kErrorNamingFile, ...) or -signal.
int readInChild(const Reader& reader, const fs::path& path, std::string& message) {
  int pipeFd[2];
  if (pipe(pipeFd) != 0) return -1000;
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    close(pipeFd[0]);
    alarm(kAlarmSeconds);
    int code = kLoaded;
    std::string what;
    try {
      reader(path);
    } catch (const Error& e) {
      what = e.what();
      code = what.find(path.string()) != std::string::npos ? kErrorNamingFile : kErrorNotNamingFile;
    } catch (const std::exception& e) {
      what = std::string("not a pslam::Error: ") + e.what();
      code = kOtherException;
    } catch (...) {
      what = "not a std::exception";
      code = kOtherException;
    }
    if (!what.empty() && write(pipeFd[1], what.data(), what.size()) < 0) code = kOtherException;
    close(pipeFd[1]);
    std::fflush(nullptr);
    _exit(code);
  }
  close(pipeFd[1]);
  char buf[4096];
  ssize_t n;
  while ((n = read(pipeFd[0], buf, sizeof buf)) > 0) message.append(buf, static_cast<std::size_t>(n));
  close(pipeFd[0]);
  int status = 0;
  waitpid(pid, &status, 0);
  if (WIFSIGNALED(status)) return -WTERMSIG(status);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1000;
}

std::vector<fs::path> configFiles() {
  std::vector<fs::path> files;
  for (const auto& e : fs::recursive_directory_iterator(fs::path(PRIORSLAM_SOURCE_DIR) / "config"))
    if (e.path().extension() == ".ini") files.push_back(e.path());
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace

TEST(ConfigFuzz, EveryMutantLoadsOrGivesAnErrorNamingTheFile) {
  const std::vector<fs::path> files = configFiles();
  ASSERT_GE(files.size(), 20u);
  const fs::path dir = fs::temp_directory_path() / ("pslam_config_fuzz_" + std::to_string(::getpid()));
  int cases = 0, loaded = 0, refused = 0;
  for (std::size_t f = 0; f < files.size(); ++f) {
    const fs::path& original = files[f];
    const std::vector<Reader> readers = readersFor(original);
    ASSERT_FALSE(readers.empty()) << original << ": no reader for this folder";
    // The mutant keeps the file's name and folder name (the reader is chosen by them), in a folder of its own.
    const fs::path mutantDir = dir / original.parent_path().filename();
    fs::create_directories(mutantDir);
    // Its siblings as shipped beside it: a file may `include =` one of them (structure_network.ini includes
    // structure.ini), which must not be an earlier file's last mutant.
    for (const auto& e : fs::directory_iterator(original.parent_path()))
      if (e.path().extension() == ".ini")
        fs::copy_file(e.path(), mutantDir / e.path().filename(), fs::copy_options::overwrite_existing);
    const fs::path mutantPath = mutantDir / original.filename();
    const std::string text = readText(original);
    std::mt19937 rng(20240601u + static_cast<unsigned>(f));
    for (int m = 0; m <= kMutantsPerFile; ++m) {
      // Mutant 0 is the file itself; the others carry one to three mutations.
      std::string mutant = text, how = "unchanged";
      if (m > 0) {
        how.clear();
        const int count = 1 + static_cast<int>(rng() % 3);
        for (int k = 0; k < count; ++k) {
          std::string what;
          mutant = mutate(mutant, rng, what);
          how += (k ? "; " : "") + what;
        }
      }
      std::ofstream(mutantPath, std::ios::binary) << mutant;
      for (std::size_t r = 0; r < readers.size(); ++r) {
        ++cases;
        std::string message;
        const int code = readInChild(readers[r], mutantPath, message);
        const bool ok = code == kLoaded || code == kErrorNamingFile;
        EXPECT_TRUE(ok) << original.filename() << " mutant " << m << " (" << how << "), reader " << r << ": "
                        << (code < 0 ? "signal " + std::to_string(-code) : "exit " + std::to_string(code)) << ": "
                        << message << "\n--- mutant ---\n"
                        << mutant;
        loaded += code == kLoaded;
        refused += code == kErrorNamingFile;
        // The files as shipped load (the network ini: its model lives in ../shared/data and may be absent).
        if (m == 0 && original.filename().string().rfind("enet", 0) != 0) {
          EXPECT_EQ(code, kLoaded) << original << ": " << message;
        }
      }
    }
  }
  fs::remove_all(dir);
  std::printf("config fuzz: %d cases over %zu files: %d loaded, %d refused with an error naming the file\n", cases,
              files.size(), loaded, refused);
  EXPECT_GE(cases, 300);
  EXPECT_GT(refused, cases / 3);
}
