#pragma once
// A thread-safe cache keyed by exact bytes (a shape's defining numbers, not a hash of them), least
// recently used out first, within a byte budget. Holds the validator's verdicts and hulls' weights.
#include <cstddef>
#include <list>
#include <mutex>
#include <string>
#include <unordered_map>
#include <utility>

#include "distlab/gap/point_to_set.hpp"

namespace distlab::detail {

inline void append_bytes(std::string& key, const void* data, std::size_t bytes) {
  key.append(static_cast<const char*>(data), bytes);
}
inline void append_bytes(std::string& key, double x) { append_bytes(key, &x, sizeof x); }

// `bytes_of(value)` is what a value holds beyond its key (its heap storage).
template <class Value, std::size_t (*bytes_of)(const Value&)>
class ExactKeyCache {
 public:
  explicit ExactKeyCache(std::size_t capacity) : capacity_(capacity) {}

  bool find(const std::string& key, Value& out) {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto it = index_.find(key);
    if (it == index_.end()) {
      ++misses_;
      return false;
    }
    ++hits_;
    order_.splice(order_.begin(), order_, it->second);  // most recently used first
    out = it->second->second;
    return true;
  }
  void insert(const std::string& key, const Value& value) {
    const std::size_t size = cost(key, value);
    std::lock_guard<std::mutex> lock(mutex_);
    if (size > capacity_ || index_.count(key)) return;  // too big, or another thread was first
    order_.emplace_front(key, value);
    index_.emplace(key, order_.begin());
    bytes_ += size;
    evict();
  }
  void set_capacity(std::size_t bytes) {
    std::lock_guard<std::mutex> lock(mutex_);
    capacity_ = bytes;
    evict();
  }
  CacheStats stats() {
    std::lock_guard<std::mutex> lock(mutex_);
    return {order_.size(), bytes_, capacity_, hits_, misses_};
  }
  void clear() {
    std::lock_guard<std::mutex> lock(mutex_);
    index_.clear();
    order_.clear();
    bytes_ = hits_ = misses_ = 0;
  }

 private:
  // Bytes held per entry: the key twice (list and index), the value and the nodes.
  static std::size_t cost(const std::string& key, const Value& value) {
    return 2 * key.size() + sizeof(Value) + bytes_of(value) + 128;
  }
  void evict() {  // mutex_ held
    while (bytes_ > capacity_) {
      auto& last = order_.back();
      bytes_ -= cost(last.first, last.second);
      index_.erase(last.first);
      order_.pop_back();
    }
  }
  using Entries = std::list<std::pair<std::string, Value>>;
  std::mutex mutex_;
  std::size_t capacity_;
  Entries order_;
  std::unordered_map<std::string, typename Entries::iterator> index_;
  std::size_t bytes_ = 0, hits_ = 0, misses_ = 0;
};

}  // namespace distlab::detail
