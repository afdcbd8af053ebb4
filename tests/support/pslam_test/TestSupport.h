#pragma once
// Helpers shared by the test executables (header only; every priorslam_add_test target has tests/support on its
// include path).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <system_error>

#include "pslam/core/Error.h"

namespace pslam::test_support {

/// A per-process temporary folder `<tmp>/<prefix>_<pid>`, created now and removed with its content at destruction.
struct TempDir {
  std::filesystem::path path;
  explicit TempDir(const std::string& prefix)
      : path(std::filesystem::temp_directory_path() / (prefix + "_" + std::to_string(::getpid()))) {
    std::filesystem::create_directories(path);
  }
  ~TempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path, ec);
  }
  TempDir(const TempDir&) = delete;
  TempDir& operator=(const TempDir&) = delete;
};

/// An empty folder `name` in `root` (what was there before is removed); it goes when `root` does.
inline std::filesystem::path freshSubDir(const TempDir& root, const std::string& name) {
  const std::filesystem::path d = root.path / name;
  std::filesystem::remove_all(d);
  std::filesystem::create_directories(d);
  return d;
}

/// The message of the pslam::Error that `f` throws, or "" when it throws none.
template <typename F>
std::string errorOf(F&& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

/// A file's bytes ("" when it cannot be read).
inline std::string readBytes(const std::filesystem::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

}  // namespace pslam::test_support
