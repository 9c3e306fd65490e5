// Mesh import in a child process with resource limits (isolated_import.hpp).
//
// posix_spawn (not fork) because the server is multithreaded: only exec follows in the child.
// The child writes  "DLMESH2\n" u64 nv u64 nf u64 np  nv*3 double  nf*3 int32  np int32 (the
// file's polygon corner counts, surface.hpp; native byte order, same machine), or "DLERROR\n" and
// a message (exit 1), or exits 3 when its memory ran out.
#include "distlab/mesh/isolated_import.hpp"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/mman.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <new>
#include <ostream>
#include <stdexcept>

#include "distlab/geometry/asan.hpp"
#include "distlab/geometry/error.hpp"

extern char** environ;

namespace distlab::mesh {
namespace {

constexpr char kMeshMagic[] = "DLMESH2\n";
constexpr char kErrorMagic[] = "DLERROR\n";
constexpr std::size_t kMagic = 8;
constexpr int kExitInvalid = 1, kExitNoMemory = 3;

void set_limit(int resource, rlim_t soft, rlim_t hard) {
  const rlimit r{soft, hard};
  ::setrlimit(resource, &r);
}

std::string megabytes(std::size_t bytes) { return std::to_string(bytes >> 20) + " MB"; }

// Reads the child's output until EOF, the deadline or the cap. Returns false on timeout or cap.
bool read_child(int fd, std::string& data, double seconds, std::size_t cap) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  char buffer[1 << 16];
  for (;;) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - std::chrono::steady_clock::now());
    if (left.count() <= 0) return false;
    pollfd p{fd, POLLIN, 0};
    const int ready = ::poll(&p, 1, static_cast<int>(std::min<long long>(left.count(), 1000)));
    if (ready < 0 && errno != EINTR) return false;
    if (ready <= 0) continue;
    const ssize_t n = ::read(fd, buffer, sizeof buffer);
    if (n == 0) return true;
    if (n < 0) {
      if (errno == EINTR || errno == EAGAIN) continue;
      return true;  // read error: judged by what arrived and the exit status
    }
    if (data.size() + static_cast<std::size_t>(n) > cap) return false;
    data.append(buffer, static_cast<std::size_t>(n));
  }
}

// The parent trusts nothing the child sends: sizes, coordinates and indices are checked again.
SurfaceMesh decode(const std::string& data, const std::string& field, const std::string& name) {
  const auto malformed = [&] { return InvalidInput(field, name + " could not be imported (the importer's output was malformed)"); };
  if (data.size() < kMagic + 24 || data.compare(0, kMagic, kMeshMagic) != 0) throw malformed();
  std::uint64_t nv = 0, nf = 0, np = 0;
  std::memcpy(&nv, data.data() + kMagic, 8);
  std::memcpy(&nf, data.data() + kMagic + 8, 8);
  std::memcpy(&np, data.data() + kMagic + 16, 8);
  const std::uint64_t max_index = static_cast<std::uint64_t>(std::numeric_limits<int>::max());
  if (nv > max_index || nf > max_index || np > nf || data.size() != kMagic + 24 + nv * 24 + nf * 12 + np * 4)
    throw malformed();
  SurfaceMesh m;
  m.vertices.resize(static_cast<Eigen::Index>(nv), 3);
  m.faces.resize(static_cast<Eigen::Index>(nf), 3);
  const char* at = data.data() + kMagic + 24;
  for (std::uint64_t v = 0; v < nv; ++v)
    for (int k = 0; k < 3; ++k, at += 8) {
      double x;
      std::memcpy(&x, at, 8);
      if (!std::isfinite(x))
        throw InvalidInput(field, name + ": vertex " + std::to_string(v) + " has a non-finite coordinate (NaN or infinity)");
      m.vertices(static_cast<Eigen::Index>(v), k) = x;
    }
  for (std::uint64_t f = 0; f < nf; ++f)
    for (int k = 0; k < 3; ++k, at += 4) {
      std::int32_t i;
      std::memcpy(&i, at, 4);
      if (i < 0 || static_cast<std::uint64_t>(i) >= nv)
        throw InvalidInput(field, name + ": face " + std::to_string(f) + " has a vertex index out of range");
      m.faces(static_cast<Eigen::Index>(f), k) = i;
    }
  std::uint64_t fans = 0;
  for (std::uint64_t p = 0; p < np; ++p, at += 4) {
    std::int32_t k;
    std::memcpy(&k, at, 4);
    if (k < 3) throw malformed();
    fans += static_cast<std::uint64_t>(k) - 2;
    m.polygon_corners.push_back(k);
  }
  if (np > 0 && fans != nf) throw malformed();
  if (nf == 0) throw InvalidInput(field, name + " contains no triangles");
  return m;
}

}  // namespace

int import_mesh_child(const std::vector<std::string>& args, std::ostream& out) {
  if (args.size() != 3 && args.size() != 4) return 2;
  [[maybe_unused]] const std::size_t memory = std::stoull(args[1]);  // unused under ASan
  const double seconds = std::stod(args[2]);
  set_limit(RLIMIT_CORE, 0, 0);
  const auto cpu = static_cast<rlim_t>(std::ceil(std::max(seconds, 1.0)));
  set_limit(RLIMIT_CPU, cpu, cpu + 1);  // SIGXCPU at the soft limit, SIGKILL one second later
#if !defined(DISTLAB_ASAN)
  set_limit(RLIMIT_AS, memory, memory);  // ASan reserves terabytes of address space up front
#endif
  try {
    const SurfaceMesh m = load_mesh(args[0], "mesh", args.size() == 4 ? args[3] : "");
    const std::uint64_t nv = static_cast<std::uint64_t>(m.vertices.rows()), nf = static_cast<std::uint64_t>(m.faces.rows()),
                        np = m.polygon_corners.size();
    out.write(kMeshMagic, kMagic);
    out.write(reinterpret_cast<const char*>(&nv), 8);
    out.write(reinterpret_cast<const char*>(&nf), 8);
    out.write(reinterpret_cast<const char*>(&np), 8);
    for (std::uint64_t v = 0; v < nv; ++v)
      for (int k = 0; k < 3; ++k) {
        const double x = m.vertices(static_cast<Eigen::Index>(v), k);
        out.write(reinterpret_cast<const char*>(&x), 8);
      }
    for (std::uint64_t f = 0; f < nf; ++f)
      for (int k = 0; k < 3; ++k) {
        const std::int32_t i = m.faces(static_cast<Eigen::Index>(f), k);
        out.write(reinterpret_cast<const char*>(&i), 4);
      }
    for (const std::int32_t k : m.polygon_corners) out.write(reinterpret_cast<const char*>(&k), 4);
    out.flush();
    return out ? 0 : 2;
  } catch (const InvalidInput& e) {
    out.write(kErrorMagic, kMagic);
    out << e.what();
    out.flush();
    return kExitInvalid;
  } catch (const std::bad_alloc&) {
    return kExitNoMemory;
  } catch (const std::length_error&) {  // a size no vector can hold
    return kExitNoMemory;
  }
}

namespace {

// Runs `exe import-mesh path memory seconds [format]`; file >= 0 is passed as the child's fd 3.
SurfaceMesh run_importer(const std::string& path, int file, const std::string& format, const std::string& field,
                         const std::string& name, const ImportLimits& limits, const std::string& exe_in) {
  // /proc/self/exe is this process's binary even if its file was replaced since it started.
  const std::string exe = exe_in.empty() ? "/proc/self/exe" : exe_in;
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw std::runtime_error("cannot create a pipe for the mesh importer");
  posix_spawn_file_actions_t actions;
  posix_spawnattr_t attr;
  ::posix_spawn_file_actions_init(&actions);
  ::posix_spawn_file_actions_adddup2(&actions, fds[1], 1);  // dup2 clears close-on-exec
  ::posix_spawn_file_actions_addopen(&actions, 0, "/dev/null", O_RDONLY, 0);
  ::posix_spawn_file_actions_addopen(&actions, 2, "/dev/null", O_WRONLY, 0);  // parsers chatter
  if (file >= 0) ::posix_spawn_file_actions_adddup2(&actions, file, 3);
  ::posix_spawn_file_actions_addclosefrom_np(&actions, file >= 0 ? 4 : 3);  // no listening socket or session file
  ::posix_spawnattr_init(&attr);
  sigset_t none, defaults;
  sigemptyset(&none);
  sigemptyset(&defaults);
  for (int s : {SIGPIPE, SIGXCPU, SIGTERM, SIGINT}) sigaddset(&defaults, s);
  ::posix_spawnattr_setsigmask(&attr, &none);
  ::posix_spawnattr_setsigdefault(&attr, &defaults);
  ::posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETSIGMASK | POSIX_SPAWN_SETSIGDEF);
  std::vector<std::string> args = {"distlab", "import-mesh", path, std::to_string(limits.memory_bytes),
                                   std::to_string(limits.seconds)};
  if (!format.empty()) args.push_back(format);
  std::vector<char*> argv;
  argv.reserve(args.size() + 1);
  for (auto& a : args) argv.push_back(a.data());
  argv.push_back(nullptr);
  pid_t pid = -1;
  const int spawned = ::posix_spawn(&pid, exe.c_str(), &actions, &attr, argv.data(), environ);
  ::posix_spawn_file_actions_destroy(&actions);
  ::posix_spawnattr_destroy(&attr);
  ::close(fds[1]);
  if (spawned != 0) {
    ::close(fds[0]);
    throw std::runtime_error(std::string("cannot start the mesh importer: ") + std::strerror(spawned));
  }
  std::string data;
  const bool finished = read_child(fds[0], data, limits.seconds, limits.memory_bytes + 64);
  ::close(fds[0]);
  if (!finished) ::kill(pid, SIGKILL);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  const std::string secs = std::to_string(static_cast<long long>(std::ceil(limits.seconds)));
  if (!finished && data.size() > limits.memory_bytes)
    throw InvalidInput(field, name + " needs more than " + megabytes(limits.memory_bytes) + " of memory to import");
  if (!finished || (WIFSIGNALED(status) && (WTERMSIG(status) == SIGXCPU || WTERMSIG(status) == SIGKILL)))
    throw InvalidInput(field, name + " took longer than " + secs + " s to import");
  if (WIFSIGNALED(status))
    throw InvalidInput(field, name + " could not be imported: the importer crashed on it (signal " +
                                  std::to_string(WTERMSIG(status)) + ")");
  const int code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  if (code == kExitNoMemory)
    throw InvalidInput(field, name + " needs more than " + megabytes(limits.memory_bytes) + " of memory to import");
  if (code == kExitInvalid && data.compare(0, kMagic, kErrorMagic) == 0)
    throw InvalidInput(field, name + ": " + data.substr(kMagic, 2000));
  if (code == 0) return decode(data, field, name);
  if (data.empty() && code == 2) throw std::runtime_error("the mesh importer is not available (" + exe + " import-mesh)");
  throw InvalidInput(field, name + " could not be imported: the importer failed on it (exit " + std::to_string(code) + ")");
}

}  // namespace

SurfaceMesh load_mesh_isolated(const std::string& path, const std::string& field, const std::string& name,
                               const ImportLimits& limits, const std::string& exe) {
  return run_importer(path, -1, "", field, name, limits, exe);
}

SurfaceMesh load_bytes_isolated(const std::string& bytes, const std::string& format, const std::string& field,
                                const std::string& name, const ImportLimits& limits, const std::string& exe) {
  // An anonymous file: nothing in any directory, so nothing is left behind if the server dies.
  const int file = ::memfd_create("distlab-upload", MFD_CLOEXEC);
  if (file < 0) throw std::runtime_error(std::string("cannot create an in-memory file: ") + std::strerror(errno));
  try {
    for (std::size_t at = 0; at < bytes.size();) {
      const ssize_t n = ::write(file, bytes.data() + at, bytes.size() - at);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) throw std::runtime_error(std::string("cannot write an in-memory file: ") + std::strerror(errno));
      at += static_cast<std::size_t>(n);
    }
    SurfaceMesh m = run_importer("/dev/fd/3", file, format, field, name, limits, exe);
    ::close(file);
    return m;
  } catch (...) {
    ::close(file);
    throw;
  }
}

}  // namespace distlab::mesh
