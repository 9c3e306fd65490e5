// Mesh import in a child process with resource limits (isolated_import.hpp).
//
// The child writes  "DLMESH2\n" u64 nv u64 nf u64 np  nv*3 double  nf*3 int32  np int32 (the
// file's polygon corner counts, surface.hpp; native byte order, same machine), or "DLERROR\n" and
// a message (exit 1), or exits 3 when its memory ran out.
#include "distlab/mesh/isolated_import.hpp"

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <new>
#include <ostream>
#include <stdexcept>

#include "distlab/geometry/asan.hpp"
#include "distlab/geometry/child_process.hpp"
#include "distlab/geometry/error.hpp"

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
  std::vector<std::string> args = {"distlab", "import-mesh", path, std::to_string(limits.memory_bytes),
                                   std::to_string(limits.seconds)};
  if (!format.empty()) args.push_back(format);
  std::string data;
  int status = 0;
  bool finished = false;
  {
    ChildProcess child(exe, args, file);
    finished = child.read(data, limits.seconds, limits.memory_bytes + 64) == ChildProcess::End::eof;
    if (!finished) child.kill();
    status = child.wait();
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
  const MemoryFile file("distlab-upload", bytes);
  return run_importer("/dev/fd/3", file.fd(), format, field, name, limits, exe);
}

}  // namespace distlab::mesh
