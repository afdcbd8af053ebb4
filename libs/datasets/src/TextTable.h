#pragma once
// Internal helpers shared by the dataset readers: line-oriented text tables (TUM lists, KITTI poses and
// times, EuRoC csv) read with the file and line number kept, so every malformed line can be named.
#include <filesystem>
#include <string>
#include <vector>

namespace pslam::datasets::detail {

struct TextRow {
  int line = 0;                     ///< 1-based line number in the file
  std::vector<std::string> fields;  ///< whitespace (and, if asked, comma) separated fields
};

/// Reads every non-blank line that does not start with '#'. Throws pslam::Error naming the file when it
/// cannot be opened.
std::vector<TextRow> readTextTable(const std::filesystem::path& file, bool commaSeparated);

/// Parses a finite double; throws pslam::Error "<file>:<line>: <what> '<text>' is not a finite number".
double parseNumber(const std::string& text, const std::filesystem::path& file, int line, const std::string& what);

/// Parses a non-negative integer (e.g. nanosecond stamps, frame ids) with the same error style.
long long parseInteger(const std::string& text, const std::filesystem::path& file, int line,
                       const std::string& what);

/// Throws "<file>:<line>: malformed line: expected <expected>" unless the row has at least `minFields`.
void requireFields(const TextRow& row, std::size_t minFields, const std::filesystem::path& file,
                   const std::string& expected);

/// "<file>:<line>"
std::string where(const std::filesystem::path& file, int line);

/// Image files (png, jpg, jpeg, bmp, tif, tiff, ppm, pgm) directly in `dir`, in natural order
/// (numeric runs compared by value, so 2.png < 10.png).
std::vector<std::filesystem::path> listImages(const std::filesystem::path& dir);

/// Natural ("human") order of file names.
bool naturalLess(const std::string& a, const std::string& b);

}  // namespace pslam::datasets::detail
