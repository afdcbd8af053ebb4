#pragma once
// Outputs are never half-written: they are produced under a temporary name in the destination folder and
// renamed into place only once complete (rename is atomic within one file system).
#include <filesystem>
#include <functional>
#include <iosfwd>
#include <string>

namespace pslam {

/// RAII guard for one output path. Write to tempPath(); commit() renames it onto finalPath().
/// If the guard is destroyed without commit() (an exception, an early return), the temporary is removed.
/// Works for files and for directories.
class AtomicOutput {
 public:
  explicit AtomicOutput(std::filesystem::path finalPath);
  ~AtomicOutput();
  AtomicOutput(const AtomicOutput&) = delete;
  AtomicOutput& operator=(const AtomicOutput&) = delete;

  const std::filesystem::path& tempPath() const { return temp_; }
  const std::filesystem::path& finalPath() const { return final_; }
  /// Replaces any existing finalPath() with tempPath(). Throws pslam::Error on failure.
  void commit();
  bool committed() const { return committed_; }

 private:
  std::filesystem::path final_;
  std::filesystem::path temp_;
  bool committed_ = false;
};

/// Writes a text/binary file atomically through `writer`. Throws pslam::Error naming the path on failure.
void writeFileAtomically(const std::filesystem::path& path,
                         const std::function<void(std::ostream&)>& writer);

/// Creates the parent folder of `path` if needed (no-op for a bare file name).
void ensureParentDirectory(const std::filesystem::path& path);

}  // namespace pslam
