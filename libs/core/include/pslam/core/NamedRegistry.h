#pragma once
// A thread-safe table of factories by name: how swappable parts (pose solvers, map initializers, ...) are chosen
// from a configuration key, and how tests or embedding programs add their own without touching the caller.
#include <map>
#include <mutex>
#include <string>
#include <vector>

#include "pslam/core/Error.h"

namespace pslam {

template <class Factory>
class NamedRegistry {
 public:
  explicit NamedRegistry(std::map<std::string, Factory> builtIn) : factories_(std::move(builtIn)) {}

  /// The factory registered under `name`. Throws pslam::Error("<key> = <name>: unknown <what> (known: a, b)")
  /// for an unknown name; `key` is the configuration key that chose it, e.g. "[System] poseSolver".
  Factory get(const std::string& name, const std::string& key, const std::string& what) const {
    std::lock_guard<std::mutex> lk(mutex_);
    auto it = factories_.find(name);
    if (it != factories_.end()) return it->second;
    std::string known;
    for (const auto& [n, f] : factories_) known += (known.empty() ? "" : ", ") + n;
    throw Error(key + " = " + name + ": unknown " + what + " (known: " + known + ")");
  }
  /// Adds or replaces the factory under `name`.
  void add(const std::string& name, Factory factory) {
    require(!name.empty() && static_cast<bool>(factory), "registry", "needs a name and a factory");
    std::lock_guard<std::mutex> lk(mutex_);
    factories_[name] = std::move(factory);
  }

 private:
  mutable std::mutex mutex_;
  std::map<std::string, Factory> factories_;
};

}  // namespace pslam
