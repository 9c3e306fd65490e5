// The field store (store.hpp): leases of preparations, publication of entries, eviction, and the
// listing and checks of `distlab cache`. Only link, rename, unlink and the mtime are relied on
// across processes (no flock, no O_EXCL across machines: NFS before v3 did not honour it).
#include <fcntl.h>
#include <signal.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string_view>

#include "distlab/geometry/error.hpp"
#include "distlab/kelvin/digest.hpp"
#include "store_impl.hpp"

namespace distlab::kelvin {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

// A temporary, lock or set-aside file untouched this long belongs to nobody (a write takes seconds
// and a lease is renewed every lease / 4), whichever machine made it.
constexpr double kOrphanSeconds = 3600;
constexpr auto kFirstPoll = std::chrono::milliseconds(10);
constexpr auto kLongestPoll = std::chrono::milliseconds(500);
constexpr char kEntrySuffix[] = ".kelvin";
constexpr char kLockSuffix[] = ".kelvin.lock";
constexpr int kRenewedWidth = 17;  // "%017.3f" of Unix seconds

double unix_now() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }
double seconds(const struct timespec& t) { return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec); }

std::string random_hex(std::size_t bytes) {
  std::string raw(bytes, '\0');
  for (std::size_t got = 0; got < raw.size();) {
    const ssize_t n = ::getrandom(raw.data() + got, raw.size() - got, 0);
    if (n <= 0) throw std::runtime_error("cannot read random bytes");
    got += static_cast<std::size_t>(n);
  }
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (const char c : raw) {
    out += kHex[(static_cast<unsigned char>(c) >> 4) & 15];
    out += kHex[static_cast<unsigned char>(c) & 15];
  }
  return out;
}

std::string read_small_file(const std::string& path) {
  std::ifstream in(path);
  std::string s;
  std::getline(in, s);
  return s;
}

// Start of a process in clock ticks after boot (/proc/PID/stat, field 22): with the pid it names
// one process, even after the pid is reused.
std::string process_start(long pid) {
  const std::string s = read_small_file("/proc/" + std::to_string(pid) + "/stat");
  const std::size_t close = s.rfind(')');
  if (close == std::string::npos) return "";
  std::istringstream rest(s.substr(close + 1));
  std::string field;
  for (int i = 3; i <= 22 && (rest >> field); ++i) {
  }
  return rest ? field : "";
}

// This machine as the store's files name it. Processes whose `id` is equal see each other's
// pids (one boot of one kernel, one pid namespace), so a lock of a process that is gone can be
// taken over at once; on another machine (or container) only the lease tells.
struct Node {
  std::string host, id, tag;  // tag: 8 hex digits of id, in file names
};

const Node& this_node() {
  static const Node node = [] {
    Node n;
    char host[256] = {};
    if (::gethostname(host, sizeof host - 1) == 0) n.host = host;
    for (char& c : n.host)
      if (c == ' ' || c == '\n' || c == '.') c = '_';
    if (n.host.empty()) n.host = "unknown";
    const std::string boot = read_small_file("/proc/sys/kernel/random/boot_id");
    struct stat ns {};
    if (!boot.empty() && ::stat("/proc/self/ns/pid", &ns) == 0) n.id = boot + ":" + std::to_string(ns.st_ino);
    Sha256 h;
    const std::string named = n.id.empty() ? n.host + random_hex(8) : n.id;
    h.add(named.data(), named.size());
    n.tag = h.hex().substr(0, 8);
    return n;
  }();
  return node;
}

bool pid_gone(long pid) { return pid > 0 && pid != ::getpid() && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH; }

bool is_key(std::string_view s) {
  return s.size() == 64 && std::all_of(s.begin(), s.end(), [](char c) { return (c >= '0' && c <= '9') || (c >= 'a' && c <= 'f'); });
}
bool ends_with(std::string_view s, std::string_view end) { return s.size() >= end.size() && s.substr(s.size() - end.size()) == end; }

bool write_all(int fd, std::string_view data) {
  while (!data.empty()) {
    const ssize_t n = ::write(fd, data.data(), data.size());
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    data.remove_prefix(static_cast<std::size_t>(n));
  }
  return true;
}

std::string fixed_seconds(double t) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%0*.3f", kRenewedWidth, t);
  return buf;
}

// A lock file: "key value" lines, the last one "renewed", rewritten in place by the holder.
struct LockInfo {
  std::string host, node, pid_start;
  long pid = 0;
  double lease = 0, started = 0, renewed = 0;
};

LockInfo parse_lock(const std::string& text) {
  LockInfo info;
  std::istringstream in(text);
  std::string line;
  if (!std::getline(in, line) || line != "distlab-lease 1") return info;
  while (std::getline(in, line)) {
    const std::size_t space = line.find(' ');
    if (space == std::string::npos) continue;
    const std::string key = line.substr(0, space), value = line.substr(space + 1);
    try {
      if (key == "host") info.host = value;
      else if (key == "node") info.node = value;
      else if (key == "pid") info.pid = std::stol(value);
      else if (key == "pid_start") info.pid_start = value;
      else if (key == "lease") info.lease = std::stod(value);
      else if (key == "started") info.started = std::stod(value);
      else if (key == "renewed") info.renewed = std::stod(value);
    } catch (const std::exception&) {  // a torn or foreign value: not this field
    }
  }
  return info;
}

// The holder was a process of this machine that no longer runs (its pid is gone or now names a
// process started at another time).
bool holder_gone(const LockInfo& info) {
  if (info.node.empty() || info.node != this_node().id || info.pid <= 0) return false;
  if (pid_gone(info.pid)) return true;
  if (info.pid_start.empty() || info.pid == ::getpid()) return false;
  const std::string start = process_start(info.pid);  // "" if unreadable: then alive, as kill said
  return !start.empty() && start != info.pid_start;
}

// What a waiter sees of a lock: the file (opened afresh each time, which makes an NFS client
// revalidate it) and its content. Any change is a renewal.
struct LockView {
  bool exists = false;
  dev_t dev = 0;
  ino_t ino = 0;
  struct timespec mtime {};
  std::string text;
  bool same(const LockView& o) const {
    return exists == o.exists && dev == o.dev && ino == o.ino && mtime.tv_sec == o.mtime.tv_sec &&
           mtime.tv_nsec == o.mtime.tv_nsec && text == o.text;
  }
};

LockView view_lock(const std::string& lock) {
  LockView v;
  struct stat st {};
  const int fd = ::open(lock.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) {
    if (::lstat(lock.c_str(), &st) != 0) return v;  // no lock
  } else {
    char buf[4096];
    const ssize_t n = ::fstat(fd, &st) == 0 ? ::pread(fd, buf, sizeof buf, 0) : -1;
    if (n > 0) v.text.assign(buf, static_cast<std::size_t>(n));
    ::close(fd);
  }
  v.exists = true;
  v.dev = st.st_dev;
  v.ino = st.st_ino;
  v.mtime = st.st_mtim;
  return v;
}

// Removes `path` only if the file there is still the one `still` approves: the file is renamed
// aside (atomic: of two removers only one gets it), checked, and linked back if it was not the
// one (a file put there meanwhile by someone else).
bool set_aside_and_remove(const std::string& path, const std::function<bool(int fd, const struct stat&)>& still) {
  const std::string aside = private_name(path, "gone");
  if (::rename(path.c_str(), aside.c_str()) != 0) return false;
  struct stat st {};
  const int fd = ::open(aside.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  const bool remove = fd >= 0 && ::fstat(fd, &st) == 0 && still(fd, st);
  if (fd >= 0) ::close(fd);
  if (!remove) (void)::link(aside.c_str(), path.c_str());  // EEXIST: a newer one is there; ours goes
  ::unlink(aside.c_str());
  return remove;
}

bool same_lock(const LockView& seen, int fd, const struct stat& st) {
  LockView now;
  now.exists = true;
  now.dev = st.st_dev;
  now.ino = st.st_ino;
  now.mtime = st.st_mtim;
  char buf[4096];
  const ssize_t n = ::pread(fd, buf, sizeof buf, 0);
  if (n > 0) now.text.assign(buf, static_cast<std::size_t>(n));
  return now.same(seen);
}

// The parts of a private name <base>.<what>.<tag>.<pid>.<n>: false if it is not one.
bool private_parts(const std::string& name, std::string& tag, long& pid) {
  const std::size_t c = name.rfind('.');
  const std::size_t b = c == std::string::npos || c == 0 ? std::string::npos : name.rfind('.', c - 1);
  const std::size_t a = b == std::string::npos || b == 0 ? std::string::npos : name.rfind('.', b - 1);
  if (a == std::string::npos) return false;
  tag = name.substr(a + 1, b - a - 1);
  try {
    pid = std::stol(name.substr(b + 1, c - b - 1));
  } catch (const std::exception&) {
    return false;
  }
  return true;
}

bool is_leftover_name(const std::string& name) {
  return name.find(".tmp.") != std::string::npos || name.find(".gone.") != std::string::npos;
}

void require_directory(const std::string& dir) {
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) throw InvalidInput("dir", "no such cache directory: " + dir);
}

struct EntryFile {
  std::string name, path;
  std::uint64_t bytes = 0;
  double mtime = 0;
  dev_t dev = 0;
  ino_t ino = 0;
};

std::vector<EntryFile> entry_files(const std::string& dir) {
  std::vector<EntryFile> out;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (!ends_with(name, kEntrySuffix) || !is_key(std::string_view(name).substr(0, name.size() - sizeof(kEntrySuffix) + 1)))
      continue;
    struct stat st {};
    if (::lstat(e.path().c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
    out.push_back({name.substr(0, 64), e.path().string(), static_cast<std::uint64_t>(st.st_size), seconds(st.st_mtim), st.st_dev, st.st_ino});
  }
  return out;
}

}  // namespace

std::string private_name(const std::string& path, const char* what) {
  static std::atomic<std::uint64_t> calls{0};
  return path + "." + what + "." + this_node().tag + "." + std::to_string(::getpid()) + "." + std::to_string(calls.fetch_add(1));
}

std::string store_entry_path(const std::string& dir, const std::string& key) { return dir + "/" + key + kEntrySuffix; }

void touch_entry(const std::string& path) { (void)::utimensat(AT_FDCWD, path.c_str(), nullptr, 0); }

// ---- The lease ----

std::unique_ptr<PreparationLease> PreparationLease::take(const std::string& lock, double lease_seconds) {
  const Node& node = this_node();
  std::ostringstream text;
  text << "distlab-lease 1\nhost " << node.host << "\nnode " << node.id << "\npid " << ::getpid() << "\npid_start "
       << process_start(::getpid()) << "\ntoken " << random_hex(8) << "\nlease " << lease_seconds << "\nstarted "
       << fixed_seconds(unix_now()) << "\nrenewed ";
  const auto renewed_at = static_cast<off_t>(text.tellp());
  text << fixed_seconds(unix_now()) << "\n";

  // Complete before it has its name: a reader never sees half a lock.
  const std::string tmp = private_temporary(lock);
  int fd = ::open(tmp.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0644);
  if (fd < 0) throw std::runtime_error("cannot create the lock " + tmp + ": " + std::strerror(errno));
  if (!write_all(fd, text.str()) || ::fsync(fd) != 0) {
    const int err = errno;
    ::close(fd);
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot write the lock " + tmp + ": " + std::strerror(err));
  }
  bool taken = ::link(tmp.c_str(), lock.c_str()) == 0;
  if (!taken) {
    const int err = errno;
    struct stat st {};
    taken = ::fstat(fd, &st) == 0 && st.st_nlink == 2;  // NFS: a retried link that had been done
    if (!taken && err != EEXIST) {
      // No hard links on this filesystem (some FUSE and SMB mounts): an exclusive create.
      ::close(fd);
      ::unlink(tmp.c_str());
      fd = ::open(lock.c_str(), O_RDWR | O_CREAT | O_EXCL | O_CLOEXEC | O_NOFOLLOW, 0644);
      if (fd < 0 && errno == EEXIST) return nullptr;
      if (fd < 0 || !write_all(fd, text.str())) {
        const int e = errno;
        if (fd >= 0) ::close(fd);
        throw std::runtime_error("cannot create the lock " + lock + ": " + std::strerror(e));
      }
      return std::unique_ptr<PreparationLease>(new PreparationLease(lock, fd, renewed_at, lease_seconds));
    }
  }
  ::unlink(tmp.c_str());
  if (!taken) {
    ::close(fd);
    return nullptr;
  }
  return std::unique_ptr<PreparationLease>(new PreparationLease(lock, fd, renewed_at, lease_seconds));
}

PreparationLease::PreparationLease(std::string lock, int fd, off_t renewed_at, double lease_seconds)
    : lock_(std::move(lock)), fd_(fd), renewed_at_(renewed_at) {
  struct stat st {};
  if (::fstat(fd_, &st) == 0) {
    dev_ = st.st_dev;
    ino_ = st.st_ino;
  }
  const auto period = std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(std::max(lease_seconds, 0.04) / 4));
  heartbeat_.emplace(period, [this] { renew(); });
}

// In place, same width: a waiter reading meanwhile sees a change either way.
void PreparationLease::renew() const {
  const std::string now = fixed_seconds(unix_now());
  if (::pwrite(fd_, now.data(), now.size(), renewed_at_) == static_cast<ssize_t>(now.size())) (void)::fdatasync(fd_);
}

PreparationLease::~PreparationLease() {
  heartbeat_.reset();
  struct stat st {};
  if (::stat(lock_.c_str(), &st) == 0 && st.st_dev == dev_ && st.st_ino == ino_) ::unlink(lock_.c_str());
  ::close(fd_);
}

std::unique_ptr<PreparationLease> await_entry(const FieldStore& store, const std::string& path,
                                              const std::function<bool()>& load, const Progress& progress,
                                              double* waited) {
  const std::string lock = path + ".lock";
  struct stat refused {};  // the entry file load refused: not read again
  bool any_refused = false;
  auto try_entry = [&] {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) return false;
    if (any_refused && st.st_dev == refused.st_dev && st.st_ino == refused.st_ino && st.st_size == refused.st_size) return false;
    touch_entry(path);  // before reading: eviction spares it while it is read
    if (load()) return true;
    refused = st;
    any_refused = true;
    return false;
  };
  std::optional<Clock::time_point> wait_start;
  auto done = [&] {
    if (waited) *waited = wait_start ? std::chrono::duration<double>(Clock::now() - *wait_start).count() : 0.0;
  };
  if (try_entry()) {
    done();
    return nullptr;
  }
  LockView seen;
  Clock::time_point seen_at = Clock::now();
  Clock::duration poll = kFirstPoll;
  for (;;) {
    const LockView now = view_lock(lock);
    if (!now.exists) {  // nobody prepares it (or the holder just published it and left)
      if (auto lease = PreparationLease::take(lock, store.lease_seconds)) {
        done();
        if (try_entry()) return nullptr;  // published between the last look and the lease
        return lease;
      }
      continue;  // another process took it first
    }
    if (!wait_start) {
      wait_start = Clock::now();
      progress("wait", 0.0);
    }
    progress.check();
    if (!now.same(seen)) {
      seen = now;
      seen_at = Clock::now();
    }
    const LockInfo holder = parse_lock(now.text);
    const double lease = holder.lease > 0 ? holder.lease : store.lease_seconds;
    if (holder_gone(holder) || std::chrono::duration<double>(Clock::now() - seen_at).count() > lease) {
      set_aside_and_remove(lock, [&](int fd, const struct stat& st) { return same_lock(seen, fd, st); });
      continue;
    }
    std::this_thread::sleep_for(poll);
    const auto longest = std::min<Clock::duration>(kLongestPoll, std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(lease / 8)));
    poll = std::max<Clock::duration>(kFirstPoll, std::min<Clock::duration>(poll * 2, longest));
    if (try_entry()) {
      done();
      return nullptr;
    }
  }
}

void publish_entry(const std::string& tmp, const std::string& path, const std::function<bool()>& existing_ok) {
  const bool linked = ::link(tmp.c_str(), path.c_str()) == 0;
  const int err = errno;
  struct stat st {};
  if (linked || (::stat(tmp.c_str(), &st) == 0 && st.st_nlink == 2)) {  // NFS: a retried link that had been done
    ::unlink(tmp.c_str());
    touch_entry(path);
    return;
  }
  if (err == EEXIST && existing_ok()) {  // the first complete entry wins
    ::unlink(tmp.c_str());
    return;
  }
  // A refused entry is replaced; so is none where the filesystem has no hard links.
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int e = errno;
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot write cache file " + path + ": " + std::strerror(e));
  }
}

// ---- distlab cache ls | verify | gc ----

StoreListing list_store(const std::string& dir) {
  require_directory(dir);
  StoreListing out;
  for (const EntryFile& f : entry_files(dir)) {
    StoreEntry e;
    e.name = f.name;
    e.bytes = f.bytes;
    e.last_used = f.mtime;
    e.readable = read_entry_header(f.path, e);
    out.bytes += f.bytes;
    out.entries.push_back(std::move(e));
  }
  std::sort(out.entries.begin(), out.entries.end(), [](const StoreEntry& a, const StoreEntry& b) { return a.last_used > b.last_used; });
  const double now = unix_now();
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec)) {
    const std::string name = e.path().filename().string();
    if (is_leftover_name(name)) {
      out.temporaries.push_back(name);
    } else if (ends_with(name, kLockSuffix) && is_key(std::string_view(name).substr(0, 64)) && name.size() == 64 + sizeof(kLockSuffix) - 1) {
      const LockView v = view_lock(e.path().string());
      if (!v.exists) continue;
      const LockInfo info = parse_lock(v.text);
      StoreLease l;
      l.name = name.substr(0, 64);
      l.host = info.host;
      l.pid = info.pid;
      l.started = info.started;
      l.renewed = seconds(v.mtime);
      l.lease_seconds = info.lease;
      l.state = info.lease <= 0 ? "unreadable" : holder_gone(info)          ? "dead"
                                             : now - l.renewed > info.lease ? "expired"
                                                                            : "held";
      out.leases.push_back(std::move(l));
    }
  }
  std::sort(out.temporaries.begin(), out.temporaries.end());
  return out;
}

std::vector<VerifiedEntry> verify_store(const std::string& dir, bool fix) {
  require_directory(dir);
  const std::optional<std::string> key = read_cache_mac_key(dir);
  std::vector<EntryFile> files = entry_files(dir);
  std::sort(files.begin(), files.end(), [](const EntryFile& a, const EntryFile& b) { return a.name < b.name; });
  std::vector<VerifiedEntry> out;
  for (const EntryFile& f : files) {
    VerifiedEntry v;
    v.name = f.name;
    v.bytes = f.bytes;
    v.status = verify_entry(f.path, f.name, key ? &*key : nullptr);
    if (fix && v.status != "ok")  // not one a writer put there since it was read
      v.removed = set_aside_and_remove(f.path, [&](int, const struct stat& st) {
        return st.st_dev == f.dev && st.st_ino == f.ino && static_cast<std::uint64_t>(st.st_size) == f.bytes;
      });
    out.push_back(std::move(v));
  }
  return out;
}

GcReport gc_store(const FieldStore& store) {
  require_directory(store.dir);
  GcReport report;
  const double now = unix_now();
  std::error_code ec;
  // Leftovers of processes that are gone.
  for (const auto& e : fs::directory_iterator(store.dir, ec)) {
    const std::string name = e.path().filename().string(), path = e.path().string();
    struct stat st {};
    if (::lstat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) continue;
    const double age = now - seconds(st.st_mtim);
    if (is_leftover_name(name)) {
      std::string tag;
      long pid = 0;
      const bool gone = (private_parts(name, tag, pid) && tag == this_node().tag && pid_gone(pid)) || age > kOrphanSeconds;
      if (gone && ::unlink(path.c_str()) == 0) report.removed.push_back(name);
    } else if (ends_with(name, kLockSuffix) && name.size() == 64 + sizeof(kLockSuffix) - 1) {
      const LockView v = view_lock(path);
      const LockInfo info = parse_lock(v.text);
      if (!v.exists || !(holder_gone(info) || age > std::max(kOrphanSeconds, 4 * std::max(info.lease, store.lease_seconds)))) continue;
      if (set_aside_and_remove(path, [&](int fd, const struct stat& s) { return same_lock(v, fd, s); })) report.removed.push_back(name);
    }
  }
  std::sort(report.removed.begin(), report.removed.end());
  // Eviction: least recently used first, sparing the recently used.
  std::vector<EntryFile> files = entry_files(store.dir);
  for (const EntryFile& f : files) report.bytes_before += f.bytes;
  std::uint64_t total = report.bytes_before;
  if (store.budget_bytes > 0 && total > store.budget_bytes) {
    std::sort(files.begin(), files.end(), [](const EntryFile& a, const EntryFile& b) { return a.mtime < b.mtime; });
    const double recent = now - store.keep_recent_seconds;
    for (const EntryFile& f : files) {
      if (total <= store.budget_bytes) break;
      if (f.mtime > recent) {
        ++report.kept_recent;
        continue;
      }
      const bool evicted = set_aside_and_remove(f.path, [&](int, const struct stat& st) {
        return st.st_dev == f.dev && st.st_ino == f.ino && seconds(st.st_mtim) <= recent;  // not used since listed
      });
      if (evicted) {
        total -= f.bytes;
        report.evicted.push_back(f.name);
      }
    }
  }
  report.bytes_after = total;
  return report;
}

}  // namespace distlab::kelvin
