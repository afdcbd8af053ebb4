#include "TextTable.h"

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "pslam/core/Error.h"

namespace fs = std::filesystem;

namespace pslam::datasets::detail {

std::string where(const fs::path& file, int line) { return file.string() + ":" + std::to_string(line); }

std::vector<TextRow> readTextTable(const fs::path& file, bool commaSeparated) {
  std::error_code ec;
  if (!fs::is_regular_file(file, ec)) throw Error(file.string() + ": file not found");
  std::ifstream in(file);
  if (!in) throw Error(file.string() + ": cannot open");
  std::vector<TextRow> rows;
  std::string text;
  int lineNo = 0;
  while (std::getline(in, text)) {
    ++lineNo;
    const auto first = text.find_first_not_of(" \t\r");
    if (first == std::string::npos || text[first] == '#') continue;
    if (commaSeparated) std::replace(text.begin(), text.end(), ',', ' ');
    std::istringstream ss(text);
    TextRow row;
    row.line = lineNo;
    std::string field;
    while (ss >> field) row.fields.push_back(field);
    rows.push_back(std::move(row));
  }
  return rows;
}

double parseNumber(const std::string& text, const fs::path& file, int line, const std::string& what) {
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(begin, &end);
  if (end == begin || *end != '\0' || errno == ERANGE || !std::isfinite(v))
    throw Error(where(file, line) + ": " + what + " '" + text + "' is not a finite number");
  return v;
}

long long parseInteger(const std::string& text, const fs::path& file, int line, const std::string& what) {
  const char* begin = text.c_str();
  char* end = nullptr;
  errno = 0;
  const long long v = std::strtoll(begin, &end, 10);
  if (end == begin || *end != '\0' || errno == ERANGE || v < 0)
    throw Error(where(file, line) + ": " + what + " '" + text + "' is not a non-negative integer");
  return v;
}

void requireFields(const TextRow& row, std::size_t minFields, const fs::path& file, const std::string& expected) {
  if (row.fields.size() < minFields)
    throw Error(where(file, row.line) + ": malformed line: expected " + expected + ", found " +
                std::to_string(row.fields.size()) + " field(s)");
}

bool naturalLess(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (std::isdigit(static_cast<unsigned char>(a[i])) && std::isdigit(static_cast<unsigned char>(b[j]))) {
      std::size_t i2 = i, j2 = j;
      while (i2 < a.size() && std::isdigit(static_cast<unsigned char>(a[i2]))) ++i2;
      while (j2 < b.size() && std::isdigit(static_cast<unsigned char>(b[j2]))) ++j2;
      // Compare the numeric runs by value: strip leading zeros, then length, then digits.
      std::size_t za = i, zb = j;
      while (za + 1 < i2 && a[za] == '0') ++za;
      while (zb + 1 < j2 && b[zb] == '0') ++zb;
      const std::string na = a.substr(za, i2 - za), nb = b.substr(zb, j2 - zb);
      if (na.size() != nb.size()) return na.size() < nb.size();
      if (na != nb) return na < nb;
      if ((i2 - i) != (j2 - j)) return (i2 - i) < (j2 - j);  // "01" after "1": stable, deterministic
      i = i2;
      j = j2;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  return (a.size() - i) < (b.size() - j);
}

std::vector<fs::path> listImages(const fs::path& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw Error(dir.string() + ": image folder not found");
  static const char* kExtensions[] = {".png", ".jpg", ".jpeg", ".bmp", ".tif", ".tiff", ".ppm", ".pgm"};
  std::vector<fs::path> files;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (!entry.is_regular_file()) continue;
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
    if (std::find(std::begin(kExtensions), std::end(kExtensions), ext) != std::end(kExtensions))
      files.push_back(entry.path());
  }
  std::sort(files.begin(), files.end(),
            [](const fs::path& x, const fs::path& y) { return naturalLess(x.filename().string(), y.filename().string()); });
  return files;
}

}  // namespace pslam::datasets::detail
