#include "pslam/core/AtomicFile.h"

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <csignal>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <mutex>
#include <regex>
#include <system_error>

#include <fcntl.h>
#include <sys/syscall.h>
#include <unistd.h>

#include "pslam/core/Error.h"

namespace fs = std::filesystem;

namespace pslam {

namespace {

std::string uniqueSuffix() {
  static std::atomic<unsigned> counter{0};
  return ".tmp-" + std::to_string(::getpid()) + "-" + std::to_string(counter++);
}

/// Removes the temporaries of `finalPath` (`<name>.tmp-<pid>-<n>`) left by processes that no longer exist (ended by
/// SIGKILL, a crash or a power cut, with no chance to clean up): the next output to the same place removes them.
/// A temporary of a live process (another run writing there now) is left alone.
void removeStaleTemporariesOf(const fs::path& finalPath) {
  const std::string prefix = finalPath.filename().string() + ".tmp-";
  const fs::path parent = finalPath.has_parent_path() ? finalPath.parent_path() : fs::path(".");
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(parent, ec)) {
    const std::string n = e.path().filename().string();
    if (n.size() <= prefix.size() || n.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string rest = n.substr(prefix.size());  // "<pid>-<n>"
    const auto dash = rest.find('-');
    if (dash == 0 || dash == std::string::npos || dash > 9 ||
        rest.find_first_not_of("0123456789-") != std::string::npos || rest.find('-', dash + 1) != std::string::npos ||
        dash + 1 == rest.size())
      continue;
    const pid_t pid = static_cast<pid_t>(std::stol(rest.substr(0, dash)));
    if (pid <= 0 || pid == ::getpid() || ::kill(pid, 0) == 0 || errno != ESRCH) continue;
    std::error_code rm;
    fs::remove_all(e.path(), rm);
  }
}

// ------------------------------------------------------------------ registry of live temporaries
// Fixed storage, so that the signal handler reads only memory that is never freed or reallocated. A slot is
// claimed (1), filled, then published (2); the handler only looks at published slots.
constexpr int kMaxLiveTemporaries = 64;
constexpr std::size_t kMaxTemporaryPath = 4096;
static_assert(std::atomic<int>::is_always_lock_free, "the signal handler needs lock-free atomics");

struct LiveTemporary {
  std::atomic<int> state{0};  // 0 free, 1 being filled, 2 live
  bool folder = false;
  char path[kMaxTemporaryPath];
};
LiveTemporary g_live[kMaxLiveTemporaries];

int registerTemporary(const fs::path& path, bool folder) {
  std::error_code ec;
  const fs::path abs = fs::absolute(path, ec);
  if (ec) return -1;
  const std::string& s = abs.native();
  if (s.size() + 1 > kMaxTemporaryPath) return -1;
  for (int i = 0; i < kMaxLiveTemporaries; ++i) {
    int expected = 0;
    if (g_live[i].state.compare_exchange_strong(expected, 1, std::memory_order_acq_rel)) {
      std::memcpy(g_live[i].path, s.c_str(), s.size() + 1);
      g_live[i].folder = folder;
      g_live[i].state.store(2, std::memory_order_release);
      return i;
    }
  }
  return -1;  // too many at once: still removed by the destructor, not by the signal handler
}

void unregisterTemporary(int slot) {
  if (slot >= 0) g_live[slot].state.store(0, std::memory_order_release);
}

// Async-signal-safe removal of a flat folder: its files, then the folder. Entries are listed with the raw
// getdents64 system call (opendir/readdir may allocate). A few passes, as deleting while listing may skip
// entries and another thread may still be writing into it.
void removeFlatFolder(const char* path) noexcept {
  for (int pass = 0; pass < 4; ++pass) {
    if (::rmdir(path) == 0 || errno == ENOENT) return;
#if defined(__linux__) && defined(SYS_getdents64)
    const int fd = ::open(path, O_RDONLY | O_DIRECTORY | O_CLOEXEC);
    if (fd < 0) return;
    alignas(8) char buf[4096];
    for (;;) {
      const long n = ::syscall(SYS_getdents64, fd, buf, sizeof buf);
      if (n <= 0) break;
      // struct linux_dirent64: u64 d_ino, s64 d_off, u16 d_reclen (offset 16), u8 d_type, char d_name[] (19)
      for (long off = 0; off + 19 < n;) {
        unsigned short reclen = 0;
        std::memcpy(&reclen, buf + off + 16, sizeof reclen);
        if (reclen == 0) break;
        const char* name = buf + off + 19;
        const bool dots = name[0] == '.' && (name[1] == '\0' || (name[1] == '.' && name[2] == '\0'));
        if (!dots) ::unlinkat(fd, name, 0);
        off += reclen;
      }
    }
    ::close(fd);
#else
    return;
#endif
  }
}

void removeTemporariesAndReraise(int sig) {
  const int savedErrno = errno;
  for (auto& t : g_live) {
    if (t.state.load(std::memory_order_acquire) != 2) continue;
    if (t.folder)
      removeFlatFolder(t.path);
    else
      ::unlink(t.path);
  }
  // End the process as the signal would have: default action, delivered when the handler returns (the
  // signal is blocked while its handler runs).
  ::signal(sig, SIG_DFL);
  ::raise(sig);
  errno = savedErrno;
}

// ------------------------------------------------------------------ paths
fs::path normalized(const fs::path& p) {
  std::error_code ec;
  fs::path c = fs::weakly_canonical(fs::absolute(p, ec), ec);
  if (ec) c = fs::absolute(p, ec).lexically_normal();
  if (!c.has_filename() && c.has_parent_path() && c != c.root_path()) c = c.parent_path();
  return c;
}

bool sameFile(const fs::path& a, const fs::path& b) {
  std::error_code ec;
  if (fs::equivalent(a, b, ec) && !ec) return true;
  return normalized(a) == normalized(b);
}

/// True when `inner` lies inside folder `outer` (strictly below it).
bool isInside(const fs::path& inner, const fs::path& outer) {
  const fs::path i = normalized(inner), o = normalized(outer);
  auto ii = i.begin();
  for (auto oi = o.begin(); oi != o.end(); ++oi, ++ii) {
    if (oi->empty()) continue;  // trailing separator
    if (ii == i.end() || *ii != *oi) return false;
  }
  return ii != i.end();
}

}  // namespace

// ------------------------------------------------------------------ checks
void requireReplaceable(const fs::path& path, const OutputKind& kind) {
  const std::string p = path.string();
  std::error_code ec;
  const fs::file_status link = fs::symlink_status(path, ec);
  if (ec && ec != std::errc::no_such_file_or_directory && ec != std::errc::not_a_directory)
    throw Error(p + ": cannot inspect the output path (" + ec.message() + ")");
  if (!fs::exists(link)) return;
  if (!kind.isFolder()) {
    const fs::file_status target = fs::status(path, ec);
    if (fs::is_directory(target)) throw Error(p + ": is a folder; refusing to replace it with a file");
    if (fs::exists(target) && !fs::is_regular_file(target))
      throw Error(p + ": is not a regular file; refusing to replace it");
    return;  // a regular file, a link to one, or a dangling link
  }
  if (fs::is_symlink(link)) throw Error(p + ": is a symbolic link; refusing to replace it with a folder");
  if (!fs::is_directory(link)) throw Error(p + ": is a file; refusing to replace it with a folder");
  const std::regex entry(kind.entryPattern());
  for (fs::directory_iterator it(path, ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (!fs::is_regular_file(it->symlink_status()) || !std::regex_match(name, entry))
      throw Error(p + ": holds '" + name + "', which is not an output of this kind; refusing to replace the folder");
  }
  if (ec) throw Error(p + ": cannot list the existing folder (" + ec.message() + ")");
}

void requireNotAnInput(const fs::path& output, const OutputKind& kind, const std::vector<fs::path>& inputs) {
  for (const fs::path& in : inputs) {
    if (in.empty()) continue;
    if (sameFile(output, in))
      throw Error(output.string() + ": is the input " + in.string() + "; refusing to overwrite an input");
    if (kind.isFolder() && isInside(in, output))
      throw Error(output.string() + ": holds the input " + in.string() + "; refusing to replace it");
  }
}

void ensureParentDirectory(const fs::path& path) {
  const fs::path parent = path.parent_path();
  if (parent.empty()) return;
  std::error_code ec;
  fs::create_directories(parent, ec);
  if (ec) throw Error(parent.string() + ": cannot create output folder (" + ec.message() + ")");
}

// ------------------------------------------------------------------ AtomicOutput
AtomicOutput::AtomicOutput(fs::path finalPath, OutputKind kind) : final_(std::move(finalPath)), kind_(std::move(kind)) {
  if (!final_.has_filename() && final_.has_parent_path()) final_ = final_.parent_path();  // "dir/" -> "dir"
  const fs::path name = final_.filename();
  if (final_.empty() || name.empty() || name == "." || name == ".." || final_ == final_.root_path())
    throw Error("'" + final_.string() + "': not a valid output path");
  installOutputCleanupOnSignals();
  requireReplaceable(final_, kind_);
  ensureParentDirectory(final_);
  removeStaleTemporariesOf(final_);
  temp_ = final_;
  temp_ += uniqueSuffix();
  registrySlot_ = registerTemporary(temp_, kind_.isFolder());
  // Reserve the temporary now: an output that cannot be written fails before the work starts.
  std::error_code ec;
  if (kind_.isFolder()) {
    if (!fs::create_directory(temp_, ec) && !ec) ec = std::make_error_code(std::errc::file_exists);
  } else {
    const int fd = ::open(temp_.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0666);
    if (fd < 0)
      ec = std::error_code(errno, std::generic_category());
    else
      ::close(fd);
  }
  if (ec) {
    unregisterTemporary(registrySlot_);
    throw Error(final_.string() + ": cannot create the output (" + ec.message() + ")");
  }
}

AtomicOutput::~AtomicOutput() {
  if (!committed_) {
    std::error_code ec;
    fs::remove_all(temp_, ec);
  }
  unregisterTemporary(registrySlot_);
}

void AtomicOutput::commit() {
  if (committed_) return;
  std::error_code ec;
  if (!fs::exists(fs::symlink_status(temp_, ec))) throw Error(final_.string() + ": nothing was written");
  requireReplaceable(final_, kind_);
  if (kind_.isFolder() && fs::is_directory(fs::symlink_status(final_, ec))) {
    // The previous output moves aside until the new one is in place, so a failure keeps it.
    fs::path previous = final_;
    previous += uniqueSuffix();
    fs::rename(final_, previous, ec);
    if (ec) throw Error(final_.string() + ": cannot move the previous output aside (" + ec.message() + ")");
    fs::rename(temp_, final_, ec);
    if (ec) {
      std::error_code restore;
      fs::rename(previous, final_, restore);
      throw Error(final_.string() + ": cannot move output into place (" + ec.message() + ")");
    }
    fs::remove_all(previous, ec);
  } else {
    fs::rename(temp_, final_, ec);
    if (ec) throw Error(final_.string() + ": cannot move output into place (" + ec.message() + ")");
  }
  committed_ = true;
  unregisterTemporary(registrySlot_);
  registrySlot_ = -1;
}

// ------------------------------------------------------------------ OutputSet
OutputSet::OutputSet(std::vector<fs::path> inputs) : inputs_(std::move(inputs)) {
  inputs_.erase(std::remove_if(inputs_.begin(), inputs_.end(), [](const fs::path& p) { return p.empty(); }),
                inputs_.end());
}

OutputSet::~OutputSet() = default;

AtomicOutput& OutputSet::add(const fs::path& finalPath, OutputKind kind) {
  requireNotAnInput(finalPath, kind, inputs_);
  for (const auto& o : outputs_) {
    if (sameFile(o->finalPath(), finalPath)) throw Error(finalPath.string() + ": given as two outputs");
    if (o->kind().isFolder() && isInside(finalPath, o->finalPath()))
      throw Error(finalPath.string() + ": lies inside the output folder " + o->finalPath().string());
    if (kind.isFolder() && isInside(o->finalPath(), finalPath))
      throw Error(finalPath.string() + ": holds the output " + o->finalPath().string());
  }
  outputs_.push_back(std::make_unique<AtomicOutput>(finalPath, std::move(kind)));
  return *outputs_.back();
}

void OutputSet::commit() {
  for (const auto& o : outputs_)
    if (!o->committed()) o->checkReplaceable();
  for (const auto& o : outputs_) o->commit();
}

// ------------------------------------------------------------------ writing
void writeOutputFile(const AtomicOutput& out, const std::function<void(std::ostream&)>& writer) {
  std::ofstream f(out.tempPath(), std::ios::binary | std::ios::trunc);
  if (!f) throw Error(out.finalPath().string() + ": cannot open for writing");
  writer(f);
  f.flush();
  if (!f) throw Error(out.finalPath().string() + ": write failed");
}

void writeFileAtomically(const fs::path& path, const std::function<void(std::ostream&)>& writer) {
  AtomicOutput out(path);
  writeOutputFile(out, writer);
  out.commit();
}

// ------------------------------------------------------------------ signals
void installOutputCleanupOnSignals() {
  static std::once_flag once;
  std::call_once(once, [] {
    for (int sig : {SIGINT, SIGTERM, SIGHUP}) {
      struct sigaction current {};
      if (::sigaction(sig, nullptr, &current) != 0) continue;
      if ((current.sa_flags & SA_SIGINFO) != 0 || current.sa_handler != SIG_DFL) continue;
      struct sigaction sa {};
      sa.sa_handler = &removeTemporariesAndReraise;
      sigfillset(&sa.sa_mask);
      sa.sa_flags = 0;
      ::sigaction(sig, &sa, nullptr);
    }
  });
}

}  // namespace pslam
