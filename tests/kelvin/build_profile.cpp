// distlab-kelvin-build-profile: where t_build goes (Field::Impl::build, the stage between the
// mesh and the factorization), per phase, on the unit cube of Table I, without re-meshing.
// usage: distlab-kelvin-build-profile --cache-dir DIR [--lx 0.05,0.04,0.03,0.02] [--repeat 5]
//                                     [--json FILE]
// The first run at an l_x meshes and factors once and stores the object in DIR; every timed
// build then starts from the tet mesh loaded from there. Phases are those build() times itself
// (A_OB, locator and σ sampling run on a second thread beside A_OO); "fingerprint" is an FNV-1a hash of everything build() derives
// (matrices, stars, gradient weights, roles, σ sampling, seeding grid), so two builds can be
// compared bit for bit.
#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "distlab/kelvin/field.hpp"
#include "distlab/mesh/primitives.hpp"
#include "field_impl.hpp"
#include "profile_args.hpp"

using namespace distlab;
using namespace distlab::kelvin;

namespace {

struct Fnv64 {
  std::uint64_t h = 1469598103934665603ull;
  void add(const void* data, size_t n) {
    const auto* p = static_cast<const unsigned char*>(data);
    for (size_t i = 0; i < n; ++i) h = (h ^ p[i]) * 1099511628211ull;
  }
  template <class T>
  void vec(const std::vector<T>& v) { add(v.data(), sizeof(T) * v.size()); }
  void sparse(const Eigen::SparseMatrix<double>& m) {
    Eigen::SparseMatrix<double> c = m;
    c.makeCompressed();
    add(c.outerIndexPtr(), sizeof(int) * static_cast<size_t>(c.outerSize() + 1));
    add(c.innerIndexPtr(), sizeof(int) * static_cast<size_t>(c.nonZeros()));
    add(c.valuePtr(), sizeof(double) * static_cast<size_t>(c.nonZeros()));
  }
};

std::uint64_t fingerprint(const Field::Impl& m) {
  Fnv64 f;
  f.vec(m.slot);
  f.vec(m.interior);
  f.vec(m.boundary);
  f.vec(m.domain_tets);
  f.vec(m.star_start);
  f.vec(m.star);
  f.vec(m.grad_weights);
  f.add(m.star_volume.data(), sizeof(double) * static_cast<size_t>(m.star_volume.size()));
  f.sparse(m.a_ob);
  f.sparse(m.a_oo_lower);
  f.vec(m.boundary_face);
  f.vec(m.boundary_weights);
  // Seeding grid: the seed of a lattice of points over the mesh's bounding box (finer than the
  // boxes, so every box is hit).
  const Vec3 lo = m.tm.points.colwise().minCoeff().transpose(), hi = m.tm.points.colwise().maxCoeff().transpose();
  const int n = std::max(8, static_cast<int>(3 * std::cbrt(static_cast<double>(m.locator.boxes()))));
  std::vector<int> seeds;
  seeds.reserve(static_cast<size_t>(n) * n * n);
  for (int z = 0; z < n; ++z)
    for (int y = 0; y < n; ++y)
      for (int x = 0; x < n; ++x)
        seeds.push_back(m.locator.seed(lo + (hi - lo).cwiseProduct(Vec3(x + 0.5, y + 0.5, z + 0.5) / n)));
  f.vec(seeds);
  return f.h;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

// A failing profile run ends on its uncaught exception (std::terminate prints it).
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  std::vector<double> lxs = {0.05, 0.04, 0.03, 0.02};
  std::string cache_dir, json_path;
  int repeat = 5;
  if (const int code = kelvin_profile::parse_profile_args(
          argc, argv,
          "usage: distlab-kelvin-build-profile --cache-dir DIR [--lx 0.05,0.04,0.03,0.02] [--repeat 5] [--json FILE]",
          cache_dir, lxs,
          {{"--repeat", [&](const std::string& v) { repeat = std::max(1, std::stoi(v)); }},
           {"--json", [&](const std::string& v) { json_path = v; }}});
      code >= 0)
    return code;
  const mesh::SurfaceMesh cube = mesh::box(Vec3::Ones());
  nlohmann::json out = nlohmann::json::array();
  const char* names[] = {"roles", "weights+stars", "assemble A_OO", "assemble A_OB", "locator", "sigma sampling"};
  std::printf(
      "| l_x | N_verts | N_tets | N_bnd | t_build med | roles | weights+stars | assemble A_OO | assemble A_OB | "
      "locator | sigma sampling | fingerprint |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (double lx : lxs) {
    PrepareOptions o;
    o.lx = lx;
    // One directory per l_x (the entry is found by its key, as prepare_cached names it).
    char sub[64];
    std::snprintf(sub, sizeof(sub), "/cube-lx%g", lx);
    const std::string dir = cache_dir + sub;
    std::filesystem::create_directories(dir);
    bool hit = false;
    const Field field = Field::prepare_cached(cube, o, dir, {}, &hit);
    PrepareOptions requested = o;
    requested.centre = field.centre();
    const std::string key = entry_key(prepare_key(field.surface(), requested));
    const std::string path = dir + "/" + key + ".kelvin";
    std::vector<double> total;
    std::map<std::string, std::vector<double>> phase;  // build phase -> seconds
    std::uint64_t print = 0;
    long n_verts = 0, n_tets = 0, n_bnd = 0;
    for (int r = 0; r < repeat; ++r) {
      auto impl = load_prepared(path, key, field.surface(), requested, cache_mac_key(dir));
      if (!impl) {
        std::fprintf(stderr, "cache entry %s did not load\n", path.c_str());
        return 1;
      }
      impl->oracle = std::make_unique<SurfaceOracle>(impl->surface);  // as prepare_cached does
      impl->build({});
      for (const auto& [name, seconds] : impl->build_phases) phase[name].push_back(seconds);
      total.push_back(impl->stats.t_build);
      const std::uint64_t p = fingerprint(*impl);
      if (r > 0 && p != print) {
        std::fprintf(stderr, "l_x %g: build %d gave fingerprint %016llx, build 0 %016llx (not deterministic)\n", lx, r,
                     static_cast<unsigned long long>(p), static_cast<unsigned long long>(print));
        return 1;
      }
      print = p;
      n_verts = static_cast<long>(impl->interior.size() + impl->boundary.size());
      n_tets = static_cast<long>(impl->domain_tets.size());
      n_bnd = static_cast<long>(impl->boundary.size());
    }
    char hex[17];
    std::snprintf(hex, sizeof(hex), "%016llx", static_cast<unsigned long long>(print));
    std::printf("| %g | %ld | %ld | %ld | %.3f |", lx, n_verts, n_tets, n_bnd, median(total));
    nlohmann::json row = {{"lx", lx}, {"n_verts", n_verts}, {"n_tets", n_tets}, {"n_boundary", n_bnd}, {"t_build", median(total)}, {"t_build_all", total}, {"fingerprint", hex}};
    for (const char* name : names) {
      const auto it = phase.find(name);
      if (it == phase.end()) {
        std::printf(" – |");
        continue;
      }
      std::printf(" %.3f |", median(it->second));
      row["phases"][name] = median(it->second);
    }
    std::printf(" %s |\n", hex);
    std::fflush(stdout);
    out.push_back(row);
  }
  if (!json_path.empty()) std::ofstream(json_path) << out.dump(2) << "\n";
  return 0;
}
