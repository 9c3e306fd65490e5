// On-disk cache of prepared objects: SHA-256 content names, authenticated with HMAC-SHA256
// under a key private to the cache directory, written atomically. The entry files' layout; how
// processes share them is the store's (store.cpp).
#include <fcntl.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>
#include <algorithm>
#include <cerrno>

#include <cstring>
#include <filesystem>
#include <limits>
#include <optional>
#include <utility>
#include <vector>

#include "distlab/kelvin/digest.hpp"
#include "field_impl.hpp"
#include "huge_pages.hpp"
#include "store_impl.hpp"

namespace distlab::kelvin {
namespace {

// Bump when the meshing or the file layout changes: old entries then simply miss.
constexpr char kFormat[] = "distlab-kelvin-cache-v12";
constexpr int kInputs = 7;  // requested lx, far_radius, feature_angle, centre, grading (kChosen: not given)
constexpr double kChosen = -1;
constexpr size_t kKeyBytes = 32;
constexpr char kKeyFile[] = "cache.key";

bool write_all(int fd, const void* data, std::size_t n) {
  const auto* p = static_cast<const char*>(data);
  while (n > 0) {
    const ssize_t w = ::write(fd, p, n);
    if (w < 0 && errno == EINTR) continue;
    if (w <= 0) return false;
    p += w;
    n -= static_cast<std::size_t>(w);
  }
  return true;
}

// A fresh key, written to a private temporary file, then linked in as the key file if there is
// none (the first of concurrent writers wins; false: another one did, read its key) or renamed
// over an untrusted one (`replace`).
bool new_mac_key(const std::string& path, bool replace, std::string& key) {
  key.assign(kKeyBytes, '\0');
  for (size_t got = 0; got < key.size();) {
    const ssize_t n = ::getrandom(key.data() + got, key.size() - got, 0);
    if (n <= 0) throw std::runtime_error("cannot read random bytes for the cache key");
    got += static_cast<size_t>(n);
  }
  const std::string tmp = private_temporary(path);
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_NOFOLLOW | O_CLOEXEC, 0600);
  if (fd < 0) throw std::runtime_error("cannot create the cache key " + tmp + ": " + std::strerror(errno));
  const bool ok = ::fchmod(fd, 0600) == 0 && ::write(fd, key.data(), key.size()) == static_cast<ssize_t>(key.size()) &&
                  ::fsync(fd) == 0;
  ::close(fd);
  if (ok && !replace && ::link(tmp.c_str(), path.c_str()) != 0 && errno == EEXIST) {
    ::unlink(tmp.c_str());
    return false;
  }
  if (!ok || (replace ? ::rename(tmp.c_str(), path.c_str()) != 0 : ::access(path.c_str(), F_OK) != 0)) {
    ::unlink(tmp.c_str());
    throw std::runtime_error("cannot write the cache key " + path);
  }
  if (!replace) ::unlink(tmp.c_str());
  return true;
}

// The key file if it is trusted; *exists: whether there was a file at all.
std::optional<std::string> trusted_key(const std::string& path, bool* exists) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (exists) *exists = fd >= 0;
  if (fd < 0) return std::nullopt;
  std::string key(kKeyBytes, '\0');
  struct stat st {};
  const bool ok = ::fstat(fd, &st) == 0 && S_ISREG(st.st_mode) && st.st_uid == ::geteuid() &&
                  (st.st_mode & 07777) == 0600 && st.st_size == static_cast<off_t>(kKeyBytes) &&
                  ::read(fd, key.data(), key.size()) == static_cast<ssize_t>(key.size());
  ::close(fd);
  if (!ok) return std::nullopt;
  return key;
}

}  // namespace

std::optional<std::string> read_cache_mac_key(const std::string& dir) {
  return trusted_key((std::filesystem::path(dir) / kKeyFile).string(), nullptr);
}

// The key is trusted only as a regular file (not a link) of this user, mode 0600, of exactly 32
// bytes. Anything else (another owner or mode, a truncated file) is replaced by a new key rather
// than refused: the cache is only a cache, so a new key costs one rebuild of each entry, while an
// error would stop a server over a file it can repair itself.
std::string cache_mac_key(const std::string& dir) {
  std::filesystem::create_directories(dir);
  const std::string path = (std::filesystem::path(dir) / kKeyFile).string();
  for (int attempt = 0;; ++attempt) {
    bool exists = false;
    if (auto key = trusted_key(path, &exists)) return *key;
    // No file: create it unless a concurrent writer did first (then read theirs, once more).
    std::string key;
    if (new_mac_key(path, exists || attempt > 0, key)) return key;
  }
}

namespace {

std::runtime_error write_error(const std::string& path) {
  return std::runtime_error("cannot write cache file " + path + ": " + std::strerror(errno));
}

// An entry streamed to its file as it is serialized, its MAC taken on the way, so the payload
// (mostly the factor: ~900 MB for the cube at l_x 0.02) is never held or copied in memory; that
// copy and the string's growth were most of the store's write. Progress "cache" 0.5 to 0.9 over
// the `expected` bytes.
class Writer final : public std::streambuf {
 public:
  Writer(int fd, std::string path, const std::string& mac_key, std::uint64_t expected, const Progress& progress)
      : fd_(fd),
        path_(std::move(path)),
        mac_(mac_key),
        expected_(std::max<std::uint64_t>(expected, 1)),
        chunk_(std::clamp<std::uint64_t>(expected / 64, std::uint64_t{4} << 10, std::uint64_t{16} << 20)),
        progress_(progress),
        buffer_(chunk_) {
    setp(buffer_.data(), buffer_.data() + buffer_.size());
    out.exceptions(std::ios::badbit);  // a failed write or a cancelled progress leaves as thrown
  }
  template <class T>
  void pod(const T& v) {
    raw(&v, sizeof(T));
  }
  template <class T>
  void array(const T* p, std::uint64_t n) {
    pod(n);
    raw(p, sizeof(T) * n);
  }
  void raw(const void* p, size_t n) { out.write(static_cast<const char*>(p), static_cast<std::streamsize>(n)); }
  // Everything written: the payload's size and MAC.
  std::pair<std::uint64_t, Digest> finish() {
    out.flush();
    return {written_, mac_.digest()};
  }
  std::ostream out{this};

 protected:
  int_type overflow(int_type c) override {
    drain();
    if (traits_type::eq_int_type(c, traits_type::eof())) return traits_type::not_eof(c);
    *pptr() = traits_type::to_char_type(c);
    pbump(1);
    return c;
  }
  std::streamsize xsputn(const char* s, std::streamsize n) override {
    if (n < epptr() - pptr()) return std::streambuf::xsputn(s, n);
    drain();  // a large array goes to the file as it is
    emit(s, static_cast<std::size_t>(n));
    return n;
  }
  int sync() override {
    drain();
    return 0;
  }

 private:
  void drain() {
    emit(pbase(), static_cast<std::size_t>(pptr() - pbase()));
    setp(buffer_.data(), buffer_.data() + buffer_.size());
  }
  void emit(const char* p, std::size_t n) {
    for (std::size_t done = 0; done < n;) {
      const std::size_t k = std::min(chunk_, n - done);
      mac_.add(p + done, k);
      if (!write_all(fd_, p + done, k)) throw write_error(path_);
      done += k;
      written_ += k;
      progress_("cache", 0.5 + 0.4 * std::min(1.0, static_cast<double>(written_) / static_cast<double>(expected_)));
    }
  }
  int fd_;
  std::string path_;
  HmacSha256 mac_;
  std::uint64_t expected_;
  std::size_t chunk_;  // one progress report per chunk: ~64 in all
  const Progress& progress_;
  std::vector<char> buffer_;
  std::uint64_t written_ = 0;
};

// The payload is read once into memory (huge pages: it is mostly the factor) and parsed in place.
using Payload = HugeVector<char>;

class Reader final : private std::streambuf {
 public:
  explicit Reader(Payload data) : data_(std::move(data)) { setg(data_.data(), data_.data(), data_.data() + data_.size()); }
  template <class T>
  bool pod(T& v) { return raw(&v, sizeof(T)); }
  // Reads a length-prefixed array into an Eigen matrix with the given column count.
  template <class M>
  bool matrix(M& m, Eigen::Index cols, std::uint64_t max_rows) {
    std::uint64_t n = 0;
    if (!pod(n) || n % static_cast<std::uint64_t>(cols) != 0 || n / cols > max_rows ||
        n > static_cast<std::uint64_t>(egptr() - gptr()) / sizeof(typename M::Scalar))
      return false;
    m.resize(static_cast<Eigen::Index>(n / cols), cols);
    return raw(m.data(), sizeof(typename M::Scalar) * n);
  }
  bool raw(void* p, size_t n) {
    in.read(static_cast<char*>(p), static_cast<std::streamsize>(n));
    return static_cast<bool>(in);
  }
  std::istream in{this};

 private:
  Payload data_;
};

}  // namespace

namespace {

void add_surface(Sha256& h, const mesh::SurfaceMesh& s) {
  const std::int64_t rows[2] = {s.vertices.rows(), s.faces.rows()};
  h.add(rows, sizeof(rows));
  h.add(s.vertices.data(), sizeof(double) * static_cast<size_t>(s.vertices.size()));
  h.add(s.faces.data(), sizeof(int) * static_cast<size_t>(s.faces.size()));
}

}  // namespace

std::string surface_digest(const mesh::SurfaceMesh& s) {
  Sha256 h;
  add_surface(h, s);
  return h.hex();
}

std::string prepare_key(const mesh::SurfaceMesh& s, const PrepareOptions& o) {
  Sha256 h;
  add_surface(h, s);
  const Vec3 c = o.centre.value_or(Vec3::Constant(std::nan("")));
  const double inputs[8] = {o.lx, o.far_radius, o.feature_angle, c.x(), c.y(), c.z(), o.centre ? 1.0 : 0.0, o.grading.value_or(kChosen)};
  h.add(inputs, sizeof(inputs));
  return h.hex();
}

std::string entry_key(const std::string& content_key) {
  Sha256 h;
  h.add(kFormat, sizeof(kFormat));
  h.add(content_key.data(), content_key.size());
  return h.hex();
}

void save_prepared(const Field::Impl& m, const std::string& tmp, const std::string& key,
                   const std::string& mac_key, const Progress& progress) {
  // The temporary is private to this call; the store links it in once it is complete and on disk.
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot write cache file " + tmp + ": " + std::strerror(errno));
  try {
    // Framing: u64 payload size (written last, at its place), payload, MAC.
    std::uint64_t size = 0;
    if (!write_all(fd, &size, sizeof(size))) throw write_error(tmp);
    const std::uint64_t mesh_bytes = sizeof(double) * static_cast<std::uint64_t>(m.tm.points.size()) +
                                     sizeof(int) * static_cast<std::uint64_t>(m.tm.tets.size() + m.tm.neighbours.size());
    Writer w(fd, tmp, mac_key, mesh_bytes + m.solver.saved_bytes(), progress);
    w.raw(kFormat, sizeof(kFormat));
    w.array(key.data(), key.size());
    w.array(m.surface.vertices.data(), static_cast<std::uint64_t>(m.surface.vertices.size()));
    w.array(m.surface.faces.data(), static_cast<std::uint64_t>(m.surface.faces.size()));
    const Vec3 c = m.requested.centre.value_or(m.centre);
    const double inputs[kInputs] = {m.requested.lx, m.requested.far_radius, m.requested.feature_angle, c.x(), c.y(), c.z(), m.requested.grading.value_or(kChosen)};
    w.raw(inputs, sizeof(inputs));
    const double params[5] = {m.options.feature_angle, m.stats.grading, m.stats.t_mesh, m.stats.t_decomp, static_cast<double>(m.stats.mesh_threads)};
    w.raw(params, sizeof(params));
    w.array(m.tm.points.data(), static_cast<std::uint64_t>(m.tm.points.size()));
    w.array(m.tm.tets.data(), static_cast<std::uint64_t>(m.tm.tets.size()));
    w.array(m.tm.neighbours.data(), static_cast<std::uint64_t>(m.tm.neighbours.size()));
    w.array(m.tm.in_domain.data(), static_cast<std::uint64_t>(m.tm.in_domain.size()));
    m.solver.save(w.out);
    const auto [payload_size, mac] = w.finish();
    size = payload_size;
    if (!write_all(fd, mac.data(), mac.size()) || ::pwrite(fd, &size, sizeof(size), 0) != static_cast<ssize_t>(sizeof(size)) ||
        ::fsync(fd) != 0)
      throw write_error(tmp);
  } catch (...) {
    ::close(fd);
    ::unlink(tmp.c_str());
    throw;
  }
  ::close(fd);
}

namespace {

// An entry's framing: u64 payload size, payload, HMAC-SHA256 of the payload. "" when it holds
// (payload and the stored MAC read), else "unreadable" or "truncated" (shorter or longer than
// its size says).
std::string read_framed(const std::string& path, Payload& payload, Digest& stored) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd < 0) return "unreadable";
  struct stat st {};
  std::uint64_t size = 0;
  const auto read_exactly = [&](void* p, std::size_t n) {
    for (auto* c = static_cast<char*>(p); n > 0;) {
      const ssize_t got = ::read(fd, c, n);
      if (got < 0 && errno == EINTR) continue;
      if (got <= 0) return false;
      c += got;
      n -= static_cast<std::size_t>(got);
    }
    return true;
  };
  std::string bad;
  if (::fstat(fd, &st) != 0 || !S_ISREG(st.st_mode))
    bad = "unreadable";
  else if (static_cast<std::uint64_t>(st.st_size) < sizeof(size) + stored.size() || !read_exactly(&size, sizeof(size)) ||
           size != static_cast<std::uint64_t>(st.st_size) - sizeof(size) - stored.size())
    bad = "truncated";  // or trailing garbage
  if (bad.empty()) {
    payload.resize(size);
    char extra = 0;
    if (!read_exactly(payload.data(), size) || !read_exactly(stored.data(), stored.size()) || ::read(fd, &extra, 1) != 0)
      bad = "truncated";  // it changed while read
  }
  ::close(fd);
  return bad;
}

}  // namespace

std::string verify_entry(const std::string& path, const std::string& name, const std::string* mac_key) {
  Payload payload;
  Digest stored{};
  if (std::string bad = read_framed(path, payload, stored); !bad.empty()) return bad;
  if (mac_key == nullptr) return "no_key";
  if (!same_digest(hmac_sha256(*mac_key, {payload.data(), payload.size()}), stored)) return "bad_mac";
  Reader r(std::move(payload));
  char format[sizeof(kFormat)];
  if (!r.raw(format, sizeof(format)) || std::memcmp(format, kFormat, sizeof(kFormat)) != 0) return "old_format";
  std::uint64_t key_size = 0;
  if (!r.pod(key_size) || key_size != name.size()) return "wrong_name";
  std::string stored_key(key_size, '\0');
  if (!r.raw(stored_key.data(), key_size) || stored_key != name) return "wrong_name";
  return "ok";
}

bool read_entry_header(const std::string& path, StoreEntry& e) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_NOFOLLOW | O_CLOEXEC);
  if (fd < 0) return false;
  struct stat st {};
  const auto file_size = ::fstat(fd, &st) == 0 ? static_cast<std::uint64_t>(st.st_size) : 0;
  std::uint64_t at = sizeof(std::uint64_t);  // after the payload's size
  auto read = [&](void* p, std::size_t n) {
    const bool ok = at + n <= file_size && ::pread(fd, p, n, static_cast<off_t>(at)) == static_cast<ssize_t>(n);
    at += n;
    return ok;
  };
  auto count = [&](std::uint64_t& n, std::size_t item) {  // a length-prefixed array: its length, skipped
    if (!read(&n, sizeof(n)) || n > file_size / item) return false;
    at += n * item;
    return at <= file_size;
  };
  char tag[64] = {};
  const ssize_t got = ::pread(fd, tag, sizeof(tag) - 1, static_cast<off_t>(at));
  e.format.assign(tag, got > 0 ? ::strnlen(tag, static_cast<std::size_t>(got)) : 0);
  e.current = got >= static_cast<ssize_t>(sizeof(kFormat)) && std::memcmp(tag, kFormat, sizeof(kFormat)) == 0;
  bool ok = got > 0;
  if (e.current) {  // the rest of the layout is known for this format only
    at += sizeof(kFormat);
    std::uint64_t key_size = 0, nv = 0, nf = 0, np = 0, nt = 0;
    double inputs[kInputs];
    ok = count(key_size, 1) && count(nv, sizeof(double)) && count(nf, sizeof(int)) && read(inputs, sizeof(inputs));
    at += 5 * sizeof(double);  // params
    std::uint64_t nn = 0, nd = 0;
    ok = ok && count(np, sizeof(double)) && count(nt, sizeof(int)) && count(nn, sizeof(int)) && read(&nd, sizeof(nd)) &&
         nd <= file_size;
    std::string in_domain(ok ? nd : 0, '\0');
    ok = ok && read(in_domain.data(), in_domain.size());
    if (ok) {
      e.surface_vertices = static_cast<long>(nv / 3);
      e.surface_faces = static_cast<long>(nf / 3);
      e.n_verts = static_cast<long>(np / 3);
      e.n_tets = static_cast<long>(std::count_if(in_domain.begin(), in_domain.end(), [](char c) { return c != 0; }));
      e.lx = inputs[0];
      e.far_radius = inputs[1];
      e.feature_angle = inputs[2];
      e.centre = {inputs[3], inputs[4], inputs[5]};
      e.grading = inputs[6];
    }
  }
  ::close(fd);
  return ok;
}

std::unique_ptr<Field::Impl> load_prepared(const std::string& path, const std::string& key,
                                           const mesh::SurfaceMesh& surface, const PrepareOptions& requested,
                                           const std::string& mac_key) {
  if (!requested.centre) return nullptr;
  Payload payload;
  Digest stored{};
  if (!read_framed(path, payload, stored).empty()) return nullptr;  // absent, truncated or trailing garbage
  // Corrupt, or written by someone without the key (an unkeyed checksum could be recomputed).
  if (!same_digest(hmac_sha256(mac_key, {payload.data(), payload.size()}), stored)) return nullptr;
  Reader r(std::move(payload));
  char format[sizeof(kFormat)];
  if (!r.raw(format, sizeof(format)) || std::memcmp(format, kFormat, sizeof(kFormat)) != 0) return nullptr;
  std::uint64_t key_size = 0;
  if (!r.pod(key_size) || key_size != key.size()) return nullptr;
  std::string stored_key(key_size, '\0');
  if (!r.raw(stored_key.data(), key_size) || stored_key != key) return nullptr;
  auto m = std::make_unique<Field::Impl>();
  constexpr std::uint64_t max_rows = 1ull << 31;
  double inputs[kInputs], params[5];
  if (!r.matrix(m->surface.vertices, 3, max_rows) || !r.matrix(m->surface.faces, 3, max_rows) ||
      !r.raw(inputs, sizeof(inputs)) || !r.raw(params, sizeof(params)))
    return nullptr;
  // The name is a digest: the stored inputs themselves must equal the request, bit for bit (memcmp: -0.0 and NaN payloads count as different, as they hash differently).
  const Vec3 c = requested.centre.value_or(Vec3::Constant(std::numeric_limits<double>::quiet_NaN()));
  const double wanted[kInputs] = {requested.lx, requested.far_radius, requested.feature_angle, c.x(), c.y(), c.z(), requested.grading.value_or(kChosen)};
  const auto same = [](const auto& a, const auto& b) {
    return a.rows() == b.rows() && a.cols() == b.cols() &&
           std::memcmp(a.data(), b.data(), sizeof(*a.data()) * static_cast<size_t>(a.size())) == 0;
  };
  if (std::memcmp(inputs, wanted, sizeof(inputs)) != 0 || !same(m->surface.vertices, surface.vertices) ||
      !same(m->surface.faces, surface.faces))
    return nullptr;
  if (!r.matrix(m->tm.points, 3, max_rows) ||
      !r.matrix(m->tm.tets, 4, max_rows) || !r.matrix(m->tm.neighbours, 4, max_rows))
    return nullptr;
  std::uint64_t nd = 0;
  if (!r.pod(nd) || nd != static_cast<std::uint64_t>(m->tm.tets.rows())) return nullptr;
  m->tm.in_domain.resize(nd);
  if (!r.raw(m->tm.in_domain.data(), nd)) return nullptr;
  // Indices are checked, not trusted: a stale layout must not index out of bounds.
  const auto np = static_cast<int>(m->tm.points.rows()), nt = static_cast<int>(m->tm.tets.rows());
  if (m->tm.neighbours.rows() != nt || (m->tm.tets.size() > 0 && (m->tm.tets.minCoeff() < 0 || m->tm.tets.maxCoeff() >= np)) ||
      (m->tm.neighbours.size() > 0 && (m->tm.neighbours.minCoeff() < -1 || m->tm.neighbours.maxCoeff() >= nt)) ||
      (m->surface.faces.size() > 0 && (m->surface.faces.minCoeff() < 0 || m->surface.faces.maxCoeff() >= m->surface.vertices.rows())))
    return nullptr;
  if (!m->solver.load(r.in)) return nullptr;
  m->requested = requested;
  m->options = requested;
  m->options.feature_angle = params[0];
  m->options.grading = m->stats.grading = params[1];
  m->centre = *requested.centre;
  // A cached object reports the timings of its original preparation (Stats::cached says so).
  m->stats.t_mesh = params[2];
  m->stats.t_decomp = params[3];
  m->stats.mesh_threads = static_cast<int>(params[4]);
  m->stats.cached = true;
  return m;
}

}  // namespace distlab::kelvin
