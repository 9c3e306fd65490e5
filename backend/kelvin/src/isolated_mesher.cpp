// Parallel meshing in a child process (isolated_mesher.hpp).
//
// Request, the child's fd 3: "DLMREQ2\n", the params (8 f64: lx, min_size, feature_angle, grading,
// boundary_edge_length, max_protection_evaluations, max_refinement_evaluations, expected_vertices; u64 max_vertices;
// i32 threads), u64 nv, u64 nf, nv*3 f64, nf*3 i32. Answer, its stdout: records of a tag byte, a
// u64 length and that many bytes: 'P' progress (f64 fraction, the stage's name), 'W' the warning,
// 'E' a refusal (field, NUL, message; exit 1), 'M' the mesh (u64 np, u64 nt, np*3 f64 points, nt*4
// i32 tets, nt*4 i32 neighbours, nt u8 in_domain; exit 0). Native byte order: the same machine.
#include "distlab/kelvin/isolated_mesher.hpp"

#include <sys/wait.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <optional>
#include <ostream>
#include <stdexcept>
#include <string_view>
#include <thread>

#include "distlab/geometry/child_process.hpp"
#include "distlab/geometry/error.hpp"

namespace distlab::kelvin {

int choose_mesh_threads(const MeshingParams& params) {
  if (!(eq23_vertex_bound(params) >= kParallelMeshFrom)) return 1;
  return static_cast<int>(std::max(1U, std::thread::hardware_concurrency()));
}

namespace {

constexpr char kRequestMagic[] = "DLMREQ2\n";
constexpr std::size_t kMagic = 8;
constexpr int kExitRefused = 1, kExitBadRequest = 2;
// Children asked before the mesh is made here on one thread, if they crash (not if they answer wrongly).
constexpr int kChildAttempts = 2;

template <class T>
void put(std::string& s, const T& v) {
  s.append(reinterpret_cast<const char*>(&v), sizeof v);
}

// Reads what a peer wrote; every read is bounds-checked (the parent trusts nothing the child sends).
struct Reader {
  const char* at;
  const char* end;
  template <class T>
  bool get(T& v) {
    if (static_cast<std::size_t>(end - at) < sizeof v) return false;
    std::memcpy(&v, at, sizeof v);
    at += sizeof v;
    return true;
  }
  std::size_t left() const { return static_cast<std::size_t>(end - at); }
};

std::string encode_request(const mesh::SurfaceMesh& inverted, const MeshingParams& p) {
  std::string s(kRequestMagic, kMagic);
  for (const double v : {p.lx, p.min_size, p.feature_angle, p.grading, p.boundary_edge_length,
                         p.max_protection_evaluations, p.max_refinement_evaluations, p.expected_vertices})
    put(s, v);
  put(s, static_cast<std::uint64_t>(p.max_vertices));
  put(s, static_cast<std::int32_t>(p.threads));
  put(s, static_cast<std::uint64_t>(inverted.vertices.rows()));
  put(s, static_cast<std::uint64_t>(inverted.faces.rows()));
  for (Eigen::Index v = 0; v < inverted.vertices.rows(); ++v)
    for (int k = 0; k < 3; ++k) put(s, inverted.vertices(v, k));
  for (Eigen::Index f = 0; f < inverted.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) put(s, static_cast<std::int32_t>(inverted.faces(f, k)));
  return s;
}

bool decode_request(const std::string& data, mesh::SurfaceMesh& inverted, MeshingParams& p) {
  if (data.size() < kMagic || data.compare(0, kMagic, kRequestMagic) != 0) return false;
  Reader r{data.data() + kMagic, data.data() + data.size()};
  std::uint64_t max_vertices = 0, nv = 0, nf = 0;
  std::int32_t threads = 0;
  for (double* v : {&p.lx, &p.min_size, &p.feature_angle, &p.grading, &p.boundary_edge_length,
                    &p.max_protection_evaluations, &p.max_refinement_evaluations, &p.expected_vertices})
    if (!r.get(*v)) return false;
  if (!r.get(max_vertices) || !r.get(threads) || !r.get(nv) || !r.get(nf) || threads < 1) return false;
  if (nv > r.left() / 24 || nf > r.left() / 12 || r.left() != nv * 24 + nf * 12) return false;
  p.max_vertices = max_vertices;
  p.threads = threads;
  inverted.vertices.resize(static_cast<Eigen::Index>(nv), 3);
  inverted.faces.resize(static_cast<Eigen::Index>(nf), 3);
  for (Eigen::Index v = 0; v < inverted.vertices.rows(); ++v)
    for (int k = 0; k < 3; ++k) r.get(inverted.vertices(v, k));
  for (Eigen::Index f = 0; f < inverted.faces.rows(); ++f)
    for (int k = 0; k < 3; ++k) {
      std::int32_t i = 0;
      r.get(i);
      if (i < 0 || static_cast<std::uint64_t>(i) >= nv) return false;
      inverted.faces(f, k) = i;
    }
  return true;
}

void write_record(std::ostream& out, char tag, const std::string& payload) {
  out.put(tag);
  const auto n = static_cast<std::uint64_t>(payload.size());
  out.write(reinterpret_cast<const char*>(&n), 8);
  out.write(payload.data(), static_cast<std::streamsize>(payload.size()));
  out.flush();
}

std::string encode_mesh(const TetMesh& tm) {
  std::string s;
  const auto np = static_cast<std::uint64_t>(tm.points.rows()), nt = static_cast<std::uint64_t>(tm.tets.rows());
  s.reserve(16 + np * 24 + nt * 33);
  put(s, np);
  put(s, nt);
  s.append(reinterpret_cast<const char*>(tm.points.data()), np * 24);  // row-major N × 3
  s.append(reinterpret_cast<const char*>(tm.tets.data()), nt * 16);
  s.append(reinterpret_cast<const char*>(tm.neighbours.data()), nt * 16);
  s.append(reinterpret_cast<const char*>(tm.in_domain.data()), nt);
  return s;
}

std::optional<TetMesh> decode_mesh(std::string_view payload) {
  Reader r{payload.data(), payload.data() + payload.size()};
  std::uint64_t np = 0, nt = 0;
  if (!r.get(np) || !r.get(nt)) return std::nullopt;
  const auto max_index = static_cast<std::uint64_t>(std::numeric_limits<int>::max());
  if (np > max_index || nt > max_index || r.left() != np * 24 + nt * 33) return std::nullopt;
  TetMesh tm;
  tm.points.resize(static_cast<Eigen::Index>(np), 3);
  tm.tets.resize(static_cast<Eigen::Index>(nt), 4);
  tm.neighbours.resize(static_cast<Eigen::Index>(nt), 4);
  tm.in_domain.resize(nt);
  std::memcpy(tm.points.data(), r.at, np * 24);
  std::memcpy(tm.tets.data(), r.at + np * 24, nt * 16);
  std::memcpy(tm.neighbours.data(), r.at + np * 24 + nt * 16, nt * 16);
  std::memcpy(tm.in_domain.data(), r.at + np * 24 + nt * 32, nt);
  const int n_points = static_cast<int>(np), n_tets = static_cast<int>(nt);
  if (!tm.points.allFinite()) return std::nullopt;
  for (Eigen::Index c = 0; c < tm.tets.rows(); ++c)
    for (int k = 0; k < 4; ++k)
      if (tm.tets(c, k) < 0 || tm.tets(c, k) >= n_points || tm.neighbours(c, k) < -1 || tm.neighbours(c, k) >= n_tets)
        return std::nullopt;
  for (const std::uint8_t d : tm.in_domain)
    if (d > 1) return std::nullopt;
  return tm;
}

std::string exit_name(int status) {
  if (WIFSIGNALED(status)) return "signal " + std::to_string(WTERMSIG(status));
  if (WIFEXITED(status)) return "exit " + std::to_string(WEXITSTATUS(status));
  return "status " + std::to_string(status);
}

}  // namespace

int mesh_domain_child(const std::vector<std::string>& args, std::ostream& out) {
  if (!args.empty()) return kExitBadRequest;
  std::ifstream in("/dev/fd/3", std::ios::binary);
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  mesh::SurfaceMesh inverted;
  MeshingParams params;
  if (!decode_request(data, inverted, params)) return kExitBadRequest;
  Progress progress;
  progress.report = [&out](const std::string& stage, double fraction) {
    std::string payload;
    put(payload, fraction);
    write_record(out, 'P', payload + stage);
  };
  try {
    std::string warning;
    const TetMesh tm = mesh_inverted_domain(inverted, params, progress, &warning);
    if (!warning.empty()) write_record(out, 'W', warning);
    write_record(out, 'M', encode_mesh(tm));
    return out ? 0 : kExitBadRequest;
  } catch (const InvalidInput& e) {
    write_record(out, 'E', e.field() + std::string(1, '\0') + e.what());
    return kExitRefused;
  }
}

TetMesh mesh_inverted_domain_isolated(const mesh::SurfaceMesh& inverted, const MeshingParams& params,
                                      const Progress& progress, IsolatedMeshing& report, const std::string& exe_in) {
  const std::string exe = exe_in.empty() ? "/proc/self/exe" : exe_in;
  const MemoryFile request("distlab-mesh-request", encode_request(inverted, params));
  std::string failure;  // why the last child's answer is not used
  // One child's run: its mesh, or nullopt with `failure` set; throws its refusal or Cancelled.
  // `crashed`: it died by a signal (the upstream race), so another child may well succeed.
  const auto run_child = [&](bool& crashed) -> std::optional<TetMesh> {
    std::optional<TetMesh> mesh;
    std::optional<InvalidInput> refusal;
    std::string data;
    std::size_t parsed = 0;
    // Consumes the complete records in data; false on a malformed one.
    const auto consume = [&]() -> bool {
      for (;;) {
        if (data.size() - parsed < 9) return true;
        std::uint64_t n = 0;
        std::memcpy(&n, data.data() + parsed + 1, 8);
        if (n > data.size() - parsed - 9) return true;
        const char tag = data[parsed];
        const std::string_view payload = std::string_view(data).substr(parsed + 9, n);  // the mesh is not copied
        parsed += 9 + n;
        if (tag == 'P') {
          double fraction = 0;
          if (payload.size() < 8) return false;
          std::memcpy(&fraction, payload.data(), 8);
          if (!(fraction >= 0 && fraction <= 1)) return false;
          progress(std::string(payload.substr(8)), fraction);  // throws Cancelled: the child is killed on the way out
        } else if (tag == 'W') {
          report.warning = std::string(payload);
        } else if (tag == 'E') {
          const std::size_t nul = payload.find('\0');
          if (nul == std::string::npos) return false;
          refusal.emplace(std::string(payload.substr(0, nul)), std::string(payload.substr(nul + 1)));
        } else if (tag == 'M') {
          mesh = decode_mesh(payload);
          if (!mesh) return false;
        } else {
          return false;
        }
      }
    };
    ChildProcess child(exe, {"distlab", "mesh-domain"}, request.fd(), /*quiet=*/false);
    bool malformed = false;
    // Cap: the vertex budget's mesh (~7 cells per vertex) with room to spare; no wall-clock limit,
    // the budgets are counts (MeshingParams).
    const double cap = 1e6 + 400.0 * static_cast<double>(params.max_vertices);
    const auto end = child.read(data, std::numeric_limits<double>::infinity(),
                                static_cast<std::size_t>(std::min(cap, 1e12)), [&] {
                                  progress.check();
                                  malformed = malformed || !consume();
                                  return !malformed;
                                });
    if (end != ChildProcess::End::eof) child.kill();
    const int status = child.wait();
    if (!malformed && end == ChildProcess::End::eof) malformed = !consume();
    progress.check();
    const bool exited = WIFEXITED(status);
    if (refusal && exited && WEXITSTATUS(status) == kExitRefused) throw *refusal;
    if (mesh && exited && WEXITSTATUS(status) == 0 && !malformed && parsed == data.size()) return mesh;
    const bool answered = malformed || end == ChildProcess::End::cap || (exited && WEXITSTATUS(status) == 0);
    crashed = !answered && WIFSIGNALED(status);
    failure = answered ? "answered no valid mesh" : "failed (" + exit_name(status) + ")";
    return std::nullopt;
  };
  const auto said = [&](const std::string& then) {
    return "the parallel mesher (" + std::to_string(params.threads) + " threads, in a child process) " + failure + "; " + then;
  };
  // A crash is the upstream race (isolated_mesher.hpp, ~1 in 1,000): a second child is as fast as
  // the first and fails as rarely; a child that crashes twice, or answers wrongly, is not asked again.
  for (int attempt = 1; attempt <= kChildAttempts; ++attempt) {
    bool crashed = false;
    report.warning.clear();
    if (std::optional<TetMesh> mesh = run_child(crashed)) {
      report.threads = params.threads;
      return std::move(*mesh);
    }
    if (!crashed || attempt == kChildAttempts) break;
    report.crashes.push_back(said("meshed again in a new child"));
    std::fprintf(stderr, "distlab: %s\n", report.crashes.back().c_str());
  }
  report.retried = said("meshed again on one thread");
  std::fprintf(stderr, "distlab: %s\n", report.retried.c_str());
  MeshingParams one = params;
  one.threads = 1;
  report.threads = 1;
  report.warning.clear();
  return mesh_inverted_domain(inverted, one, progress, &report.warning);
}

}  // namespace distlab::kelvin
