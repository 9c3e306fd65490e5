#pragma once
// The field store's protocol (store.hpp) as Field::prepare_cached and the cache I/O use it.
#include <sys/types.h>

#include <functional>
#include <memory>
#include <optional>
#include <string>

#include "distlab/geometry/periodic.hpp"
#include "distlab/kelvin/progress.hpp"
#include "distlab/kelvin/store.hpp"

namespace distlab::kelvin {

// A name next to `path` that no other writer uses, on this machine or another:
// <path>.<what>.<node>.<pid>.<n> (node: this machine's boot and pid namespace, hashed).
std::string private_name(const std::string& path, const char* what);
inline std::string private_temporary(const std::string& path) { return private_name(path, "tmp"); }

// The lease of one preparation: <entry>.lock, renewed by a thread of its own until destroyed,
// then removed if it is still this one.
class PreparationLease {
 public:
  // Takes the lease (the lock file made complete, then linked in): nullptr if another holds it.
  static std::unique_ptr<PreparationLease> take(const std::string& lock, double lease_seconds);
  ~PreparationLease();
  PreparationLease(const PreparationLease&) = delete;
  PreparationLease& operator=(const PreparationLease&) = delete;

 private:
  PreparationLease(std::string lock, int fd, off_t renewed_at, double lease_seconds);
  void renew() const;

  std::string lock_;
  int fd_;
  off_t renewed_at_;  // offset of the fixed-width "renewed" value in the file
  dev_t dev_ = 0;
  ino_t ino_ = 0;
  std::optional<Periodic> heartbeat_;  // renews the lease; stopped before the lock file goes
};

// Until `load` takes the entry at `path` (true) or this call holds the entry's lease: returns
// the lease, or nullptr when loaded. load runs again whenever another entry file appears there
// (it is not retried on a file it refused). Meanwhile waits for a preparation another process
// holds (progress stage "wait"; Cancelled through progress) and takes over a dead or expired
// one. *waited: seconds spent waiting for another holder.
std::unique_ptr<PreparationLease> await_entry(const FieldStore& store, const std::string& path,
                                              const std::function<bool()>& load, const Progress& progress,
                                              double* waited);

// Makes the complete temporary `tmp` the entry at `path` and removes tmp: linked in if there is
// none (the first complete entry wins: if one appeared meanwhile and existing_ok() says it is
// servable, tmp is dropped), renamed over one that is not servable.
void publish_entry(const std::string& tmp, const std::string& path, const std::function<bool()>& existing_ok);

// Records a use of the entry (its mtime: what eviction orders by).
void touch_entry(const std::string& path);

// The store's key if it has a trusted one (cache_mac_key's rules), without making one.
std::optional<std::string> read_cache_mac_key(const std::string& dir);
// Entry files (cache.cpp knows their layout): the header of `path` into e (false: unreadable),
// and the verdict of verify_store on it (mac_key null: the store has none).
bool read_entry_header(const std::string& path, StoreEntry& e);
std::string verify_entry(const std::string& path, const std::string& name, const std::string* mac_key);

}  // namespace distlab::kelvin
