// e2e: every row of the bad-input table of doc/reliability-config.md, run with the built tools. The table is
// the specification: a row added there is a case here. Each tool must refuse the input with a non-zero exit
// code before writing any output, the first line of its error output must contain the row's expected text, and
// a second line may only be CLI11's --help hint.
#include <gtest/gtest.h>

#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <memory>
#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

const fs::path kBin = fs::path(PRIORSLAM_BINARY_DIR) / "bin";
const char* const kBegin = "<!-- config-error-cases: begin -->";
const char* const kEnd = "<!-- config-error-cases: end -->";
const char* const kCliHint = "Run with --help for more information.";

struct Case {
  int line = 0;
  std::string tool, command, ini, expected;
};

struct ToolRun {
  int code = -1;
  std::string out, err;
};

std::string readText(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

// The table of the doc (doc/reliability-config.md, or doc/reliability.md once the two are one page).
fs::path docPath() {
  const fs::path doc = fs::path(PRIORSLAM_SOURCE_DIR) / "doc";
  for (const char* name : {"reliability-config.md", "reliability.md"})
    if (fs::exists(doc / name) && readText(doc / name).find(kBegin) != std::string::npos) return doc / name;
  return doc / "reliability-config.md";
}

std::vector<Case> readCases(const fs::path& doc) {
  std::ifstream in(doc);
  std::vector<Case> cases;
  std::string line;
  bool inTable = false;
  int lineNo = 0;
  const std::regex code("`([^`]*)`");
  while (std::getline(in, line)) {
    ++lineNo;
    if (line.find(kBegin) != std::string::npos) inTable = true;
    if (line.find(kEnd) != std::string::npos) break;
    if (!inTable || line.rfind("| ", 0) != 0 || line.find('`') == std::string::npos) continue;
    // | tool | `command` | `ini` or - | `expected` |
    std::vector<std::string> cells;
    std::stringstream ss(line.substr(1));
    std::string cell;
    while (std::getline(ss, cell, '|')) cells.push_back(cell);
    if (cells.size() < 4) {
      ADD_FAILURE() << doc << ":" << lineNo << ": expected 4 cells";
      continue;
    }
    auto codeOf = [&](const std::string& c) -> std::string {
      std::smatch m;
      return std::regex_search(c, m, code) ? m[1].str() : std::string();
    };
    Case k;
    k.line = lineNo;
    k.tool = std::regex_replace(cells[0], std::regex("^ +| +$"), "");
    k.command = codeOf(cells[1]);
    k.ini = codeOf(cells[2]);
    k.expected = codeOf(cells[3]);
    cases.push_back(k);
  }
  return cases;
}

std::string unescape(const std::string& text) {
  std::string out;
  for (std::size_t i = 0; i < text.size(); ++i) {
    if (text[i] == '\\' && i + 1 < text.size() && text[i + 1] == 'n') {
      out += '\n';
      ++i;
    } else {
      out += text[i];
    }
  }
  return out + "\n";
}

// Runs `argv` (first word: a tool in <build>/bin) in `dir` with a time limit; stdout and stderr apart.
ToolRun runIn(const fs::path& dir, const std::vector<std::string>& argv) {
  std::string cmd = "cd '" + dir.string() + "' && timeout 120 '" + (kBin / argv[0]).string() + "'";
  for (std::size_t i = 1; i < argv.size(); ++i) cmd += " '" + argv[i] + "'";
  cmd += " 2> stderr.txt";
  std::unique_ptr<FILE, int (*)(FILE*)> pipe(popen(cmd.c_str(), "r"), pclose);
  ToolRun r;
  std::array<char, 4096> buf{};
  while (fgets(buf.data(), buf.size(), pipe.get())) r.out += buf.data();
  const int status = pclose(pipe.release());
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  r.err = readText(dir / "stderr.txt");
  fs::remove(dir / "stderr.txt");
  return r;
}

std::vector<std::string> words(const std::string& s) {
  std::vector<std::string> w;
  std::stringstream ss(s);
  std::string x;
  while (ss >> x) w.push_back(x);
  return w;
}

class ConfigErrorsCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = fs::temp_directory_path() / ("pslam_config_errors_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    // x.rawlog, x_groundtruth.txt, x_Images/, x_Labels/: 3 frames of the synthetic room.
    const ToolRun r = runIn(dir_, {"slam-synth", "--scenario", "room", "--frames", "3", "--width", "64", "--height", "48",
                               "--out", ".", "--name", "x", "--quiet"});
    ASSERT_EQ(r.code, 0) << r.err;
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static fs::path dir_;
};
fs::path ConfigErrorsCli::dir_;

}  // namespace

TEST_F(ConfigErrorsCli, EveryRowOfTheTableIsRefusedWithItsError) {
  const fs::path doc = docPath();
  const std::vector<Case> cases = readCases(doc);
  ASSERT_GE(cases.size(), 50u) << doc;
  std::set<std::string> tools;
  for (const Case& k : cases) {
    SCOPED_TRACE(doc.string() + ":" + std::to_string(k.line) + ": " + k.command);
    const std::vector<std::string> argv = words(k.command);
    ASSERT_FALSE(argv.empty());
    EXPECT_EQ(argv[0], k.tool);
    tools.insert(k.tool);
    ASSERT_FALSE(k.expected.empty());
    const fs::path work = dir_ / ("case_" + std::to_string(k.line));
    fs::create_directories(work);
    // The inputs by their names in the table, as links into this case's folder.
    for (const char* name : {"x.rawlog", "x_groundtruth.txt", "x_Images", "x_Labels"})
      fs::create_symlink(dir_ / name, work / name);
    if (!k.ini.empty() && k.ini != "-") std::ofstream(work / "BAD.ini") << unescape(k.ini);
    const ToolRun r = runIn(work, argv);
    EXPECT_NE(r.code, 0) << r.out << r.err;
    EXPECT_NE(r.code, 124) << "timed out";
    const std::string first = r.err.substr(0, r.err.find('\n'));
    EXPECT_NE(first.find(k.expected), std::string::npos) << "error output:\n" << r.err;
    const std::string rest = r.err.find('\n') == std::string::npos ? "" : r.err.substr(r.err.find('\n') + 1);
    EXPECT_TRUE(rest.empty() || rest == std::string(kCliHint) + "\n") << "more than one line:\n" << r.err;
    // Nothing written: the error comes before any output.
    for (const char* out : {"out", "out.rawlog", "out_Images"}) EXPECT_FALSE(fs::exists(work / out)) << out;
  }
  for (const char* tool : {"slam-run", "bench-slam", "slam-eval", "slam-synth", "manhattan-eval", "normal-priors",
                           "semantic-priors", "dataset2rawlog", "bench-features"})
    EXPECT_TRUE(tools.count(tool)) << "no row for " << tool;
}
