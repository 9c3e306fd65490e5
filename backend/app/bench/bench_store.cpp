// The field store (Field::prepare_cached, kelvin/store.hpp) beside what a user would otherwise do:
// prepare the field again (Field::prepare), and write the same bytes with write(2) + fsync.
//   distlab-bench-store [--lx 0.05,0.03] [--grading auto|g] [--dir DIR] [--json bench_store.json]
// Per l_x of the unit cube: t_prepare (no store), the store's write (its "cache" stage from 0.5
// to 1, timed by the progress it reports: streaming, MAC, fsync, publishing), the entry's MB,
// the plain write of as many bytes, t_load of a hit (Stats::t_load: read, MAC, parse, rebuild)
// and prepare / load. Wall clock; the load average is printed before and after.
#include <fcntl.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <sstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "../src/huge_page_heap.hpp"
#include "distlab/kelvin/field.hpp"
#include "distlab/kelvin/store.hpp"
#include "distlab/mesh/primitives.hpp"
#include "load_average.hpp"

using namespace distlab;
using namespace distlab::kelvin;
namespace fs = std::filesystem;

namespace {

using Clock = std::chrono::steady_clock;
double since(Clock::time_point t0) { return std::chrono::duration<double>(Clock::now() - t0).count(); }

// write(2) of `bytes` bytes in 16 MB pieces, then fsync: the disk's own speed for an entry's size.
double plain_write_seconds(const fs::path& path, std::uint64_t bytes) {
  const std::vector<char> piece(std::size_t{16} << 20, 'x');
  const auto t0 = Clock::now();
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) throw std::runtime_error("cannot write " + path.string());
  for (std::uint64_t done = 0; done < bytes;) {
    const std::size_t n = static_cast<std::size_t>(std::min<std::uint64_t>(piece.size(), bytes - done));
    if (::write(fd, piece.data(), n) != static_cast<ssize_t>(n)) throw std::runtime_error("cannot write " + path.string());
    done += n;
  }
  if (::fsync(fd) != 0) throw std::runtime_error("cannot fsync " + path.string());
  ::close(fd);
  const double s = since(t0);
  fs::remove(path);
  return s;
}

}  // namespace

int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape): a benchmark may stop on a bad argument
  distlab::app::use_huge_page_heap(argv);
  std::vector<double> lxs = {0.05, 0.03};
  std::optional<double> grading;
  std::string dir = (fs::temp_directory_path() / "distlab-bench-store").string(), json_path = "bench_store.json";
  for (int i = 1; i + 1 < argc; i += 2) {
    const std::string k = argv[i], v = argv[i + 1];
    if (k == "--lx") {
      lxs.clear();
      std::stringstream ss(v);
      for (std::string item; std::getline(ss, item, ',');) lxs.push_back(std::stod(item));
    } else if (k == "--grading") {
      grading = v == "auto" ? std::nullopt : std::optional<double>(std::stod(v));
    } else if (k == "--dir") {
      dir = v;
    } else if (k == "--json") {
      json_path = v;
    } else {
      std::fprintf(stderr, "usage: distlab-bench-store [--lx 0.05,0.03] [--grading auto|g] [--dir DIR] [--json FILE]\n");
      return 2;
    }
  }
  const mesh::SurfaceMesh cube = mesh::box(Vec3::Ones());
  const std::string load_before = bench::load_average();
  std::printf(
      "| l_x | vertices | t_prepare s | store write s | entry MB | plain write s | write / plain | t_load s | prepare / load |\n"
      "|---|---|---|---|---|---|---|---|---|\n");
  nlohmann::json rows = nlohmann::json::array();
  for (double lx : lxs) {
    PrepareOptions o;
    o.lx = lx;
    o.grading = grading;
    fs::remove_all(dir);
    const auto t0 = Clock::now();
    const Field plain = Field::prepare(cube, o);
    const double t_prepare = since(t0);

    std::optional<Clock::time_point> write_from;
    double t_write = 0;
    Progress progress;
    progress.report = [&](const std::string& stage, double f) {
      if (stage != "cache" || f < 0.5) return;
      if (!write_from) write_from = Clock::now();
      if (f >= 1) t_write = since(*write_from);
    };
    bool hit = true;
    const Field stored = Field::prepare_cached(cube, o, FieldStore{dir}, progress, &hit);
    if (hit) throw std::runtime_error("a fresh store hit");
    const StoreListing listing = list_store(dir);
    if (listing.entries.size() != 1) throw std::runtime_error("the store holds no single entry");
    const std::uint64_t bytes = listing.entries[0].bytes;
    const double t_plain = plain_write_seconds(fs::path(dir) / "plain.bin", bytes);
    const Field loaded = Field::prepare_cached(cube, o, FieldStore{dir}, {}, &hit);
    if (!hit) throw std::runtime_error("the stored entry was not served");
    const double t_load = loaded.stats().t_load;
    const double mb = static_cast<double>(bytes) / 1e6;
    std::printf("| %.3g | %ld | %.2f | %.2f | %.0f | %.2f | %.2f | %.2f | %.1f |\n", lx, plain.stats().n_verts, t_prepare, t_write, mb,
                t_plain, t_write / t_plain, t_load, t_prepare / t_load);
    std::fflush(stdout);
    rows.push_back({{"lx", lx}, {"n_verts", plain.stats().n_verts}, {"grading", plain.stats().grading}, {"t_prepare", t_prepare}, {"t_store_write", t_write}, {"entry_mb", mb}, {"t_plain_write", t_plain}, {"t_load", t_load}});
  }
  fs::remove_all(dir);
  const std::string load_after = bench::load_average();
  std::printf("load average (1/5/15 min): before %s, after %s\n", load_before.c_str(), load_after.c_str());
  std::ofstream(json_path) << nlohmann::json{{"rows", rows}, {"load_before", load_before}, {"load_after", load_after}}.dump(2) << "\n";
  return 0;
}
