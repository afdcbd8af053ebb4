// doc/reliability.md is kept in sync by the tests: every table row names the tests that check it (last column,
// `Suite.Name`); each must exist, and its source file must contain every fragment quoted in the "Expected" column.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

namespace fs = std::filesystem;

namespace {

const fs::path kSource = PRIORSLAM_SOURCE_DIR;

std::string readAll(const fs::path& p) {
  std::ifstream f(p, std::ios::binary);
  std::stringstream ss;
  ss << f.rdbuf();
  return ss.str();
}

/// The `quoted` fragments of a markdown cell.
std::vector<std::string> quoted(const std::string& cell) {
  std::vector<std::string> out;
  std::size_t a = 0;
  while ((a = cell.find('`', a)) != std::string::npos) {
    const std::size_t b = cell.find('`', a + 1);
    if (b == std::string::npos) break;
    out.push_back(cell.substr(a + 1, b - a - 1));
    a = b + 1;
  }
  return out;
}

std::vector<std::string> cells(const std::string& row) {
  std::vector<std::string> out;
  std::string cell;
  bool inCode = false;
  for (std::size_t i = 1; i < row.size(); ++i) {  // row starts with '|'
    const char c = row[i];
    if (c == '`') inCode = !inCode;
    if (c == '|' && !inCode) {
      out.push_back(cell);
      cell.clear();
    } else {
      cell += c;
    }
  }
  return out;
}

/// Test name "Suite.Name" -> source file, for every TEST / TEST_F of the repository's test sources.
std::map<std::string, fs::path> testsInSources() {
  std::map<std::string, fs::path> tests;
  const std::regex def(R"(^\s*TEST(?:_F)?\(\s*(\w+)\s*,\s*(\w+)\s*\))");
  for (const char* top : {"libs", "apps", "tests"}) {
    for (const auto& e : fs::recursive_directory_iterator(kSource / top)) {
      if (!e.is_regular_file() || e.path().extension() != ".cpp") continue;
      std::ifstream in(e.path());
      std::string line;
      std::smatch m;
      while (std::getline(in, line))
        if (std::regex_search(line, m, def)) tests[m[1].str() + "." + m[2].str()] = e.path();
    }
  }
  return tests;
}

}  // namespace

TEST(ReliabilityDoc, EveryRowNamesExistingTestsThatCheckItsMessage) {
  const fs::path doc = kSource / "doc" / "reliability.md";
  ASSERT_TRUE(fs::exists(doc)) << doc;
  const auto tests = testsInSources();
  std::ifstream in(doc);
  std::string line;
  int rows = 0;
  while (std::getline(in, line)) {
    if (line.rfind("| ", 0) != 0 || line.rfind("| Tool", 0) == 0) continue;
    const auto c = cells(line);
    ASSERT_GE(c.size(), 4u) << line;
    const auto names = quoted(c.back());
    EXPECT_FALSE(names.empty()) << "row without a test: " << line;
    for (const std::string& name : names) {
      const auto it = tests.find(name);
      if (it == tests.end()) {
        ADD_FAILURE() << "doc/reliability.md names the test " << name << ", which does not exist:\n" << line;
        continue;
      }
      const std::string source = readAll(it->second);
      for (const std::string& fragment : quoted(c[c.size() - 2]))
        EXPECT_NE(source.find(fragment), std::string::npos)
            << "'" << fragment << "' (doc/reliability.md) is not checked in " << it->second << " (" << name << ")";
    }
    ++rows;
  }
  EXPECT_GE(rows, 30) << "the tables of doc/reliability.md were not found";
}
