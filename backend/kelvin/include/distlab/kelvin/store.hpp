#pragma once
// The field store (issue 35, item 2): the cache directory of prepared fields
// (Field::prepare_cached), shared by threads, processes and machines (a shared filesystem, NFS
// included: only link, rename and O_EXCL-free creation are relied on, never flock).
//
//  <dir>/cache.key                 the HMAC key (32 bytes, mode 0600; the first key file wins)
//  <dir>/<key>.kelvin              an entry: <key> is the SHA-256 of everything that determines it
//  <dir>/<key>.kelvin.lock         the lease of a preparation of that entry in progress
//  <dir>/<key>.kelvin.tmp.<id>     a writer's private temporary (never read as an entry)
//
// - An entry is written to a private temporary, flushed, and linked to its name: readers see no
//   entry or a complete one, and the first complete entry wins (a later writer drops its copy,
//   unless the entry there is one its reader refused: then it renames its own over it). Every
//   read checks the entry's MAC and compares its stored inputs with the request.
// - A preparation holds <key>.kelvin.lock (host, process and its start, lease; made complete, then
//   linked in) and renews it every lease / 4. A process that wants the same entry waits for the
//   entry (progress stage "wait", cancellable), and takes over when the holder is gone: a holder
//   on this machine whose process died at once, any other once the lock has not changed for the
//   lease (by the waiter's own clock, so clocks need not agree across machines). A stale lock is
//   broken by renaming it aside and checking it is the one judged stale, so two waiters never
//   both take over one lock.
// - With a budget, the writer of an entry evicts the entries least recently used (loads touch
//   the entry's mtime) until the entries fit, sparing those used in the last keep_recent_seconds
//   (a reader on another machine may hold one open; on one machine an open file outlives its
//   name anyway).
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace distlab::kelvin {

inline constexpr double kDefaultLeaseSeconds = 60;
inline constexpr double kDefaultKeepRecentSeconds = 60;

// A store and how a preparation uses it (Field::prepare_cached).
struct FieldStore {
  std::string dir;
  // After writing an entry, evict the least recently used entries until all take at most this
  // many bytes (0: no budget).
  std::uint64_t budget_bytes = 0;
  // A preparation's lease: renewed every lease_seconds / 4 while it runs; a waiter takes over a
  // lock it has not seen change for this long.
  double lease_seconds = kDefaultLeaseSeconds;
  // Eviction spares entries written or loaded this recently.
  double keep_recent_seconds = kDefaultKeepRecentSeconds;
};

// The path of an entry: <dir>/<key>.kelvin.
std::string store_entry_path(const std::string& dir, const std::string& key);

// An entry as its header describes it (not verified: see verify_store).
struct StoreEntry {
  std::string name;  // the content key (64 hex digits); the file is <name>.kelvin
  std::uint64_t bytes = 0;
  double last_used = 0;   // Unix seconds: written or last loaded (the file's mtime)
  bool readable = false;  // the header below could be read
  std::string format;     // its format tag
  bool current = false;   // format is the one this build reads and writes
  long surface_vertices = 0, surface_faces = 0;
  long n_verts = 0, n_tets = 0;  // of the prepared field (Stats::n_verts, n_tets)
  double lx = 0, far_radius = 0, feature_angle = 0;
  double grading = -1;  // as requested; -1: not given (chosen by the preparation)
  std::array<double, 3> centre{};
};

// A preparation in progress (its lock).
struct StoreLease {
  std::string name;  // the entry it prepares
  std::string host;  // the holder's host name, process id
  long pid = 0;
  double started = 0;  // Unix seconds, the holder's clock
  double renewed = 0;  // Unix seconds: the lock's last change (the file's mtime)
  double lease_seconds = 0;
  // "held"; "dead": the holder was a process of this machine that is gone (the next waiter takes
  // over at once); "expired": not renewed for its lease by this machine's clock (taken over as
  // soon as a waiter has seen that much); "unreadable".
  std::string state;
};

struct StoreListing {
  std::vector<StoreEntry> entries;  // by last use, most recent first
  std::vector<StoreLease> leases;
  std::vector<std::string> temporaries;  // writers' temporaries (in progress, or left by a crash)
  std::uint64_t bytes = 0;               // of the entries
};
// Throws InvalidInput("dir") if dir is not a directory.
StoreListing list_store(const std::string& dir);

struct VerifiedEntry {
  std::string name;
  std::uint64_t bytes = 0;
  // "ok"; "truncated" (shorter or longer than its framing says); "bad_mac" (not written under
  // this store's key: damaged, forged, or from before the key was replaced); "no_key" (the store
  // has no trusted key, so no entry can be served); "old_format" (another format version: never
  // read again); "wrong_name" (its content key is not its name).
  std::string status;
  bool removed = false;  // by fix
};
// Reads every entry whole and checks its MAC, format and name. fix: removes the bad ones (an
// entry replaced meanwhile by a writer is kept). Throws InvalidInput("dir") if dir is not a
// directory.
std::vector<VerifiedEntry> verify_store(const std::string& dir, bool fix);

struct GcReport {
  std::vector<std::string> evicted;                 // entries removed for the budget, least recently used first
  std::uint64_t bytes_before = 0, bytes_after = 0;  // of the entries
  std::size_t kept_recent = 0;                      // entries over the budget spared as recently used
  // Leftovers of processes that died: temporaries, locks of dead holders or not renewed for an
  // hour (and 4 leases), files set aside by a removal.
  std::vector<std::string> removed;
};
// Evicts for store.budget_bytes (none if 0) and removes leftovers. Safe beside running
// preparations, readers and other gc runs. Throws InvalidInput("dir") if not a directory.
GcReport gc_store(const FieldStore& store);

}  // namespace distlab::kelvin
