#pragma once
// Helpers of the seeded mutation-fuzz tests (doc/reliability.md): byte-level mutations of a valid file, a
// guard that ends the test program if one case hangs, and a memory cap so that a mutated size field makes
// an allocation fail (std::bad_alloc) instead of filling the machine's memory.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <mutex>
#include <random>
#include <string>
#include <thread>

#include <sys/resource.h>
#include <unistd.h>

namespace pslam::testing {

/// One seeded mutation of `in`: flipped bytes, truncation, zero-fill to the end, a zeroed range, inserted or
/// deleted bytes. `what` describes it (for the failure message).
inline std::string mutateBytes(const std::string& in, std::mt19937& rng, std::string& what) {
  std::string s = in;
  auto pos = [&](std::size_t n) { return std::uniform_int_distribution<std::size_t>(0, n == 0 ? 0 : n - 1)(rng); };
  const int kind = std::uniform_int_distribution<int>(0, 5)(rng);
  switch (kind) {
    case 0: {  // 1-4 bytes XORed with a non-zero mask
      const int n = std::uniform_int_distribution<int>(1, 4)(rng);
      what = "xor";
      for (int i = 0; i < n && !s.empty(); ++i) {
        const std::size_t at = pos(s.size());
        const int mask = std::uniform_int_distribution<int>(1, 255)(rng);
        s[at] = static_cast<char>(s[at] ^ mask);
        what += " @" + std::to_string(at);
      }
      break;
    }
    case 1: {
      const std::size_t at = pos(s.size());
      s.resize(at);
      what = "truncate @" + std::to_string(at);
      break;
    }
    case 2: {
      const std::size_t at = pos(s.size());
      std::fill(s.begin() + static_cast<std::ptrdiff_t>(at), s.end(), '\0');
      what = "zero-fill from @" + std::to_string(at);
      break;
    }
    case 3: {
      const std::size_t at = pos(s.size());
      const std::size_t n = std::min<std::size_t>(s.size() - at, std::uniform_int_distribution<std::size_t>(1, 64)(rng));
      std::fill_n(s.begin() + static_cast<std::ptrdiff_t>(at), n, '\0');
      what = "zero " + std::to_string(n) + " @" + std::to_string(at);
      break;
    }
    case 4: {
      const std::size_t at = pos(s.size() + 1);
      const std::size_t n = std::uniform_int_distribution<std::size_t>(1, 16)(rng);
      std::string bytes(n, '\0');
      for (char& c : bytes) c = static_cast<char>(std::uniform_int_distribution<int>(0, 255)(rng));
      s.insert(at, bytes);
      what = "insert " + std::to_string(n) + " @" + std::to_string(at);
      break;
    }
    default: {
      const std::size_t at = pos(s.size());
      const std::size_t n = std::min<std::size_t>(s.size() - at, std::uniform_int_distribution<std::size_t>(1, 16)(rng));
      s.erase(at, n);
      what = "delete " + std::to_string(n) + " @" + std::to_string(at);
      break;
    }
  }
  return s;
}

/// Ends the program with a message if one case runs longer than `limit`: a guard against hangs only (the
/// cases take milliseconds; nothing is timed).
class HangGuard {
 public:
  explicit HangGuard(std::chrono::seconds limit) : limit_(limit), thread_([this] { watch(); }) {}
  ~HangGuard() {
    stop_ = true;
    thread_.join();
  }
  void startCase(const std::string& description) {
    std::lock_guard<std::mutex> lock(mutex_);
    current_ = description;
    started_ = std::chrono::steady_clock::now();
  }

 private:
  void watch() {
    while (!stop_) {
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      std::lock_guard<std::mutex> lock(mutex_);
      if (!current_.empty() && std::chrono::steady_clock::now() - started_ > limit_) {
        std::fprintf(stderr, "fuzz case hangs (> %lld s): %s\n", static_cast<long long>(limit_.count()),
                     current_.c_str());
        std::fflush(stderr);
        std::_Exit(3);
      }
    }
  }
  std::chrono::seconds limit_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::string current_;
  std::chrono::steady_clock::time_point started_;
  std::thread thread_;
};

/// Caps the address space of the test process at its current size plus `extraBytes` (not under
/// AddressSanitizer, which reserves terabytes of shadow memory), so that a mutated count or size that asks for
/// gigabytes fails as std::bad_alloc instead of filling the memory of the machine.
inline void capAddressSpace(std::size_t extraBytes) {
#if defined(__SANITIZE_ADDRESS__)
  (void)extraBytes;
#else
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
  (void)extraBytes;
  return;
#endif
#endif
  std::size_t pages = 0;
  if (FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%zu", &pages) != 1) pages = 0;
    std::fclose(f);
  }
  if (pages == 0) return;
  const rlim_t limit = static_cast<rlim_t>(pages * static_cast<std::size_t>(sysconf(_SC_PAGESIZE)) + extraBytes);
  rlimit r{limit, limit};
  setrlimit(RLIMIT_AS, &r);
#endif
}

}  // namespace pslam::testing
