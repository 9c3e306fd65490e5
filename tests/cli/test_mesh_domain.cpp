// Parallel meshing in a child process (kelvin/isolated_mesher.hpp) with the real `distlab
// mesh-domain` child: the mesh crosses the pipe unchanged, refusals keep their field, a
// cancellation kills the child, a child that crashes is run once more, and one that crashes twice
// or forges its answer costs a second meshing on one thread here, never a wrong mesh. Stand-in
// children are small shell scripts.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "distlab/geometry/error.hpp"
#include "distlab/kelvin/isolated_mesher.hpp"
#include "distlab/mesh/primitives.hpp"
#include "temp_dir.hpp"

namespace fs = std::filesystem;
using namespace distlab;
using namespace distlab::kelvin;

namespace {

// A sphere of radius 0.5 around (0.1, -0.05, 0.08), inverted about the origin (eq. 5), and eq.
// 23's sizing at l_x 0.12 (a few thousand vertices).
mesh::SurfaceMesh inverted_sphere() {
  mesh::SurfaceMesh m = mesh::icosphere(0.5, 3, Vec3(0.1, -0.05, 0.08));
  for (Eigen::Index v = 0; v < m.vertices.rows(); ++v) m.vertices.row(v) /= m.vertices.row(v).squaredNorm();
  return m;
}

MeshingParams params(int threads) {
  MeshingParams p;
  p.lx = 0.12;
  p.min_size = p.lx / (0.7 * 0.7);
  p.threads = threads;
  return p;
}

void expect_same(const TetMesh& a, const TetMesh& b) {
  ASSERT_EQ(a.points.rows(), b.points.rows());
  ASSERT_EQ(a.tets.rows(), b.tets.rows());
  EXPECT_EQ(a.points, b.points);
  EXPECT_EQ(a.tets, b.tets);
  EXPECT_EQ(a.neighbours, b.neighbours);
  EXPECT_EQ(a.in_domain, b.in_domain);
}

// The stand-in children and their files are in this program's folder.
fs::path scratch(const std::string& name) { return test::process_temp_dir() / name; }

std::string script(const std::string& name, const std::string& body) {
  const std::string path = test::process_temp_dir().write(name, "#!/bin/sh\n" + body + "\n");
  ::chmod(path.c_str(), 0755);
  return path;
}

bool no_child_left() {
  int status = 0;
  return ::waitpid(-1, &status, WNOHANG) < 0 && errno == ECHILD;
}

TEST(IsolatedMesher, TheChildsMeshIsThisProcesssOnOneThread) {
  const mesh::SurfaceMesh inverted = inverted_sphere();
  const TetMesh here = mesh_inverted_domain(inverted, params(1), {});
  std::vector<double> fractions;
  Progress progress;
  progress.report = [&](const std::string& stage, double f) {
    EXPECT_EQ(stage, "mesh");
    fractions.push_back(f);
  };
  IsolatedMeshing report;
  const TetMesh there = mesh_inverted_domain_isolated(inverted, params(1), progress, report, DISTLAB_EXE);
  expect_same(there, here);
  EXPECT_GT(here.points.rows(), 500);
  EXPECT_EQ(report.threads, 1);
  EXPECT_TRUE(report.retried.empty()) << report.retried;
  ASSERT_FALSE(fractions.empty());
  EXPECT_TRUE(std::is_sorted(fractions.begin(), fractions.end()));
  EXPECT_EQ(fractions.back(), 1.0);
  EXPECT_TRUE(no_child_left());
}

TEST(IsolatedMesher, TwoThreadsInTheChildMakeAValidMesh) {
  const mesh::SurfaceMesh inverted = inverted_sphere();
  const TetMesh one = mesh_inverted_domain(inverted, params(1), {});
  IsolatedMeshing report;
  const TetMesh two = mesh_inverted_domain_isolated(inverted, params(2), {}, report, DISTLAB_EXE);
  ASSERT_TRUE(report.retried.empty()) << report.retried;
  EXPECT_EQ(report.threads, 2);
  // A different mesh of the same domain: its vertex count within a few percent, every cell
  // positively oriented, neighbours symmetric.
  EXPECT_NEAR(static_cast<double>(two.points.rows()), static_cast<double>(one.points.rows()), 0.1 * static_cast<double>(one.points.rows()));
  for (Eigen::Index c = 0; c < two.tets.rows(); ++c) {
    const Vec3 a = two.points.row(two.tets(c, 0)), b = two.points.row(two.tets(c, 1)), d = two.points.row(two.tets(c, 2)),
               e = two.points.row(two.tets(c, 3));
    ASSERT_GT((b - a).cross(d - a).dot(e - a), 0) << c;
    for (int k = 0; k < 4; ++k) {
      const int n = two.neighbours(c, k);
      if (n < 0) continue;
      bool back = false;
      for (int j = 0; j < 4; ++j) back = back || two.neighbours(n, j) == c;
      ASSERT_TRUE(back) << c << " " << n;
    }
  }
}

TEST(IsolatedMesher, ARefusalKeepsItsField) {
  MeshingParams p = params(2);
  p.max_refinement_evaluations = 1000;
  p.feature_angle = 180;
  std::string here;
  try {
    mesh_inverted_domain(inverted_sphere(), p, {});
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "lx");
    here = e.what();
  }
  ASSERT_FALSE(here.empty());
  IsolatedMeshing report;
  try {
    mesh_inverted_domain_isolated(inverted_sphere(), p, {}, report, DISTLAB_EXE);
    ADD_FAILURE() << "no refusal";
  } catch (const InvalidInput& e) {
    EXPECT_EQ(e.field(), "lx");
    EXPECT_EQ(std::string(e.what()), here);
  }
}

TEST(IsolatedMesher, ACancellationKillsTheChild) {
  std::atomic<bool> cancel{false};
  Progress progress;
  progress.cancel = &cancel;
  progress.report = [&](const std::string&, double) { cancel = true; };
  MeshingParams p = params(2);
  p.lx = 0.02;  // seconds of meshing, unless the cancellation stops it
  p.min_size = p.lx / (0.7 * 0.7);
  IsolatedMeshing report;
  EXPECT_THROW(mesh_inverted_domain_isolated(inverted_sphere(), p, progress, report, DISTLAB_EXE), Cancelled);
  EXPECT_TRUE(no_child_left());
}

// A child that dies by a signal (CGAL's race) is run once more; one that dies twice, or answers
// wrongly, costs a meshing here on one thread. Each stand-in counts its runs in a file.
TEST(IsolatedMesher, ACrashedOrLyingChildIsMeshedAgainOnOneThread) {
  const mesh::SurfaceMesh inverted = inverted_sphere();
  const TetMesh here = mesh_inverted_domain(inverted, params(1), {});
  // A mesh record whose cell names a vertex that does not exist.
  const std::string forged_answer =
      "printf 'M\\111\\000\\000\\000\\000\\000\\000\\000'; "  // 73 bytes: np 1, nt 1
      "printf '\\001\\000\\000\\000\\000\\000\\000\\000\\001\\000\\000\\000\\000\\000\\000\\000'; "
      "head -c 24 /dev/zero; printf '\\005\\000\\000\\000'; head -c 12 /dev/zero; "  // cell (5, 0, 0, 0)
      "head -c 16 /dev/zero | tr '\\000' '\\377'; head -c 1 /dev/zero";              // no neighbours, outside
  const struct {
    std::string name, body, why;
    int runs;
  } children[] = {{"segfault", "kill -SEGV $$", "signal 11", 2},
                  {"abort", "kill -ABRT $$", "signal 6", 2},
                  {"garbage", "echo this is not a mesh", "no valid mesh", 1},
                  {"forged", forged_answer, "no valid mesh", 1},
                  {"silent", "exit 0", "no valid mesh", 1},
                  {"refusing", "exit 1", "exit 1", 1}};
  for (const auto& child : children) {
    const fs::path runs = scratch(child.name + ".runs");
    fs::remove(runs);
    const std::string exe = script(child.name, "echo run >> '" + runs.string() + "'; " + child.body);
    IsolatedMeshing report;
    const TetMesh again = mesh_inverted_domain_isolated(inverted, params(2), {}, report, exe);
    EXPECT_NE(report.retried.find(child.why), std::string::npos) << child.name << ": " << report.retried;
    EXPECT_EQ(report.threads, 1) << child.name;
    EXPECT_EQ(report.crashes.size(), static_cast<std::size_t>(child.runs - 1)) << child.name;
    std::ifstream counted(runs);
    std::string line;
    int n = 0;
    while (std::getline(counted, line)) ++n;
    EXPECT_EQ(n, child.runs) << child.name;
    expect_same(again, here);
  }
  EXPECT_TRUE(no_child_left());
}

// A child that crashes once is replaced by another: the mesh is still refined on two threads, and
// the crash is reported.
TEST(IsolatedMesher, AChildThatCrashesOnceIsRunAgainInParallel) {
  const fs::path flag = scratch("crash_once.crashed");
  fs::remove(flag);
  const std::string exe = script("crash_once", "if [ ! -e '" + flag.string() + "' ]; then touch '" + flag.string() +
                                                   "'; kill -SEGV $$; fi; exec '" DISTLAB_EXE "' \"$@\"");
  IsolatedMeshing report;
  const TetMesh two = mesh_inverted_domain_isolated(inverted_sphere(), params(2), {}, report, exe);
  EXPECT_TRUE(fs::exists(flag));
  EXPECT_TRUE(report.retried.empty()) << report.retried;
  EXPECT_EQ(report.threads, 2);
  ASSERT_EQ(report.crashes.size(), 1u);
  EXPECT_NE(report.crashes[0].find("signal 11"), std::string::npos) << report.crashes[0];
  EXPECT_GT(two.tets.rows(), 100);
  EXPECT_TRUE(no_child_left());
}

TEST(IsolatedMesher, ChoosesThreadsByEq23sBound) {
  MeshingParams small = params(0), big = params(0);
  big.lx = 0.01;
  big.min_size = big.lx / (0.7 * 0.7);
  ASSERT_LT(eq23_vertex_bound(small), kParallelMeshFrom);
  ASSERT_GE(eq23_vertex_bound(big), kParallelMeshFrom);
  EXPECT_EQ(choose_mesh_threads(small), 1);
  EXPECT_EQ(choose_mesh_threads(big), static_cast<int>(std::max(1U, std::thread::hardware_concurrency())));
}

}  // namespace
