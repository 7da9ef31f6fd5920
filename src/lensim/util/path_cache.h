// A process-wide cache of immutable tables loaded from files, one per path.
#pragma once

#include <map>
#include <memory>
#include <mutex>
#include <string>

namespace lensim {

/// The table `load(path)` returns, loaded once per process for each path and shared afterwards
/// (thread-safe; the lock is not held while loading, so two threads asking for a new path at once
/// may both load it, and the first one stored is the one every caller gets). One cache per T.
template <class T, class Load>
std::shared_ptr<const T> loadOncePerPath(const std::string& path, Load&& load) {
  static std::mutex mutex;
  static std::map<std::string, std::shared_ptr<const T>> cache;
  {
    std::lock_guard lock(mutex);
    if (auto it = cache.find(path); it != cache.end()) return it->second;
  }
  auto table = std::make_shared<const T>(load(path));
  std::lock_guard lock(mutex);
  return cache.emplace(path, std::move(table)).first->second;
}

}  // namespace lensim
