#include "pslam/core/AtomicFile.h"

#include <atomic>
#include <fstream>
#include <random>
#include <system_error>

#include <unistd.h>

#include "pslam/core/Error.h"

namespace fs = std::filesystem;

namespace pslam {

namespace {
std::string uniqueSuffix() {
  static std::atomic<unsigned> counter{0};
  return ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
}
}  // namespace

void ensureParentDirectory(const fs::path& path) {
  const fs::path parent = path.parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) throw Error(parent.string() + ": cannot create output folder (" + ec.message() + ")");
}

AtomicOutput::AtomicOutput(fs::path finalPath) : final_(std::move(finalPath)) {
  ensureParentDirectory(final_);
  temp_ = final_;
  temp_ += uniqueSuffix();
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(temp_, ec);
  }
}

void AtomicOutput::commit() {
  if (committed_) return;
  std::error_code ec;
  if (!fs::exists(temp_, ec)) throw Error(final_.string() + ": nothing was written");
  if (fs::is_directory(final_, ec)) fs::remove_all(final_, ec);
  fs::rename(temp_, final_, ec);
  if (ec) throw Error(final_.string() + ": cannot move output into place (" + ec.message() + ")");
  committed_ = true;
}

void writeFileAtomically(const fs::path& path, const std::function<void(std::ostream&)>& writer) {
  AtomicOutput out(path);
  {
    std::ofstream f(out.tempPath(), std::ios::binary);
    if (!f) throw Error(path.string() + ": cannot open for writing");
    writer(f);
    f.flush();
    if (!f) throw Error(path.string() + ": write failed");
  }
  out.commit();
}

}  // namespace pslam
