// Point location (white box): the seeded walk finds a cell that contains the point, agreeing with
// a scan of every cell, for random points and for points on vertices, edges and faces.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "distlab/mesh/surface.hpp"
#include "distlab/mesh/weld.hpp"
#include "locator.hpp"
#include "sphere_fixture.hpp"

using namespace distlab;
using namespace distlab::kelvin;
using namespace distlab::kelvin::testing;

namespace {

// Mean face crossings of a seeded walk that the grid must beat (measured: see SeededWalksAreShort).
constexpr double kMaxMeanSeededSteps = 1.2;

double min_lambda(const TetMesh& m, int c, const Vec3& y) {
  double l[4];
  barycentric(m, c, y, l);
  return std::min(std::min(l[0], l[1]), std::min(l[2], l[3]));
}

// Brute force on the TetMesh itself (not the locator's packed copy): the cell y is most inside of.
Location scan_tet_mesh(const TetMesh& m, const Vec3& y) {
  Location best;
  double best_min = -std::numeric_limits<double>::infinity();
  for (int c = 0; c < static_cast<int>(m.tets.rows()); ++c) {
    double l[4];
    barycentric(m, c, y, l);
    const double lo = std::min(std::min(l[0], l[1]), std::min(l[2], l[3]));
    if (lo > best_min) {
      best_min = lo;
      best.cell = c;
      std::copy(l, l + 4, best.lambda);
    }
  }
  return best;
}

// A locator over a tet mesh, as Field builds it.
struct Located {
  PackedMesh packed;
  Locator locator;
  explicit Located(const TetMesh& m) : packed(m) { locator.build(packed); }
};

// Hint-less location of y agrees with the scan: both off the hull, or a containing cell that is
// the scan's or shares its boundary point. Returns whether y is inside the hull.
bool expect_agrees_with_scan(const TetMesh& m, const PackedMesh& pm, const Locator& loc, const Vec3& y, int i) {
  const Location a = loc.locate(pm, y, -1);
  const Location s = Locator::scan(pm, y);
  EXPECT_EQ(a.outside_hull, s.outside_hull) << i;
  if (a.outside_hull || s.outside_hull) return false;
  EXPECT_GE(min_lambda(m, a.cell, y), -1e-12) << i;
  if (a.cell != s.cell) {  // y lies on their common boundary
    EXPECT_NEAR(min_lambda(m, a.cell, y), min_lambda(m, s.cell, y), 1e-12) << i;
  }
  return true;
}

const Field& field() {
  static const Field f = Field::prepare(sphere_mesh(Sphere{}), sphere_options(0.1));
  return f;
}

// The wrench meshed with its inversion centre at the origin, σ = 0.3: cells from l_x-scale near
// the object's surface (|y| large) to the far-field bound, and (non-convex) cells outside Ω_inv.
Field wrench(double lx) {
  PrepareOptions o;
  o.lx = lx;
  o.centre = Vec3::Zero();
  o.feature_angle = 180;
  Field f = Field::prepare(mesh::weld(mesh::load_mesh(std::string(DISTLAB_ASSET_DIR) + "/wrench.stl")).surface, o);
  f.set_sigma(constant_sigma(0.3));
  return f;
}

Field& wrench_field() {
  static Field f = wrench(0.008);
  return f;
}

// The walk of locator.cpp written plainly over TetMesh's own arrays (rows of tets, neighbours
// and points): no records, no seeding grid copies, no prefetches. Same start, same face order
// (the same xorshift sequence), same tolerance; cell -1 if it has not ended after max_steps.
Location reference_walk(const TetMesh& m, const Vec3& y, int c, int max_steps = 100000) {
  Location loc;
  std::uint32_t rng = 2463534242u;
  for (int step = 0; step < max_steps; ++step) {
    barycentric(m, c, y, loc.lambda);
    rng ^= rng << 13, rng ^= rng >> 17, rng ^= rng << 5;
    int exit = -1;
    for (int k = 0; k < 4 && exit < 0; ++k)
      if (const int i = static_cast<int>((rng + static_cast<std::uint32_t>(k)) & 3u); loc.lambda[i] < -1e-12) exit = i;
    loc.cell = c;
    loc.steps = step;
    if (exit >= 0 && m.neighbours(c, exit) >= 0) {
      c = m.neighbours(c, exit);
      continue;
    }
    loc.outside_hull = exit >= 0;
    return loc;
  }
  loc.cell = -1;
  return loc;
}

// What the locator's walk over the packed records returns is what the plain walk returns, bit for bit.
void expect_same_location(const Location& a, const Location& r, int i) {
  ASSERT_EQ(a.cell, r.cell) << i;
  EXPECT_EQ(a.steps, r.steps) << i;
  EXPECT_EQ(a.outside_hull, r.outside_hull) << i;
  for (int k = 0; k < 4; ++k) EXPECT_EQ(a.lambda[k], r.lambda[k]) << i;
}

}  // namespace

TEST(KelvinLocator, SeededWalkAgreesWithTheScanOnRandomPoints) {
  const TetMesh& m = field().tet_mesh();
  const Located located(m);
  const Locator& loc = located.locator;
  const PackedMesh& pm = located.packed;
  const Vec3 lo = m.points.colwise().minCoeff().transpose(), hi = m.points.colwise().maxCoeff().transpose();
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  int inside = 0;
  for (int i = 0; i < 3000; ++i) {
    // Slightly beyond the box too: points outside the hull.
    const Vec3 y = lo + (hi - lo).cwiseProduct(Vec3(u(rng), u(rng), u(rng)) * 1.1 - Vec3::Constant(0.05));
    inside += expect_agrees_with_scan(m, pm, loc, y, i);
  }
  EXPECT_GT(inside, 1000);
}

TEST(KelvinLocator, PointsOnVerticesEdgesAndFacesAreFoundInAnAdjacentCell) {
  const TetMesh& m = field().tet_mesh();
  const Located located(m);
  const Locator& loc = located.locator;
  const PackedMesh& pm = located.packed;
  std::mt19937 rng(5);
  std::uniform_int_distribution<int> cell(0, static_cast<int>(m.tets.rows()) - 1);
  std::uniform_int_distribution<int> corner(0, 3);
  for (int i = 0; i < 2000; ++i) {
    const int c = cell(rng);
    const Vec3 a = m.points.row(m.tets(c, corner(rng))), b = m.points.row(m.tets(c, corner(rng))),
               d = m.points.row(m.tets(c, corner(rng)));
    for (const Vec3& y : {a, Vec3(0.5 * (a + b)), Vec3((a + b + d) / 3.0)}) {
      const Location l = loc.locate(pm, y, -1);
      ASSERT_FALSE(l.outside_hull) << i;
      EXPECT_GE(min_lambda(m, l.cell, y), -1e-12) << i;
      // With a far hint as well.
      const Location h = loc.locate(pm, y, cell(rng));
      EXPECT_GE(min_lambda(m, h.cell, y), -1e-12) << i;
    }
  }
}

TEST(KelvinLocator, EveryBoxSeedContainsTheBoxCentreUnlessItIsOffTheHull) {
  // The grid's contract: box i holds a cell containing its centre (exact barycentric test), or,
  // for a centre outside the triangulation, a hull cell (the scan agrees that it is outside).
  const TetMesh& m = field().tet_mesh();
  const Located located(m);
  const Locator& loc = located.locator;
  const PackedMesh& pm = located.packed;
  // About one box per cell, in blocks (two levels), and a stated footprint.
  EXPECT_GT(loc.boxes(), static_cast<size_t>(m.tets.rows()) / 2);
  EXPECT_LT(loc.boxes(), static_cast<size_t>(m.tets.rows()) * 3);
  EXPECT_LT(loc.blocks(), loc.boxes());
  EXPECT_EQ(loc.bytes(), loc.boxes() * (sizeof(int) + 4 * sizeof(int)) + loc.blocks() * 8);  // cell + its vertex ids
  int off_hull = 0, checked_off = 0;
  for (size_t i = 0; i < loc.boxes(); ++i) {
    const Vec3 y = loc.box_centre(i);
    const int c = loc.seed(y);
    ASSERT_GE(c, 0) << i;
    ASSERT_LT(c, m.tets.rows()) << i;
    if (min_lambda(m, c, y) >= -1e-12) continue;
    ++off_hull;
    if (checked_off < 100) {  // the scan is O(cells): check a sample of them
      ++checked_off;
      EXPECT_TRUE(Locator::scan(pm, y).outside_hull) << i;
      // Its hull cell has a face on the hull (a neighbour -1).
      EXPECT_TRUE((m.neighbours.row(c).array() < 0).any()) << i;
    }
  }
  EXPECT_LT(off_hull, static_cast<int>(loc.boxes()));
}

TEST(KelvinLocator, SeedsAreValidCellsForAnyPoint) {
  // Far outside the grid, on its faces and corners, and non-finite: a valid cell, never an
  // out-of-range index.
  const TetMesh& m = field().tet_mesh();
  const Located located(m);
  const Locator& loc = located.locator;
  const PackedMesh& pm = located.packed;
  const Vec3 lo = m.points.colwise().minCoeff().transpose(), hi = m.points.colwise().maxCoeff().transpose();
  const double inf = std::numeric_limits<double>::infinity(), nan = std::numeric_limits<double>::quiet_NaN();
  for (const Vec3& y : {lo, hi, Vec3(lo.x(), hi.y(), lo.z()), Vec3(1e300, -1e300, 0), Vec3(inf, -inf, 0),
                        Vec3(nan, 0, 0), Vec3(nan, nan, nan), Vec3(hi + (hi - lo))}) {
    const int c = loc.seed(y);
    EXPECT_GE(c, 0);
    EXPECT_LT(c, m.tets.rows());
  }
  // Points just outside the box, everywhere on its surface: located as outside, like the scan.
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> u(0, 1);
  for (int i = 0; i < 200; ++i) {
    Vec3 y = lo + (hi - lo).cwiseProduct(Vec3(u(rng), u(rng), u(rng)));
    y[i % 3] = i % 2 ? hi[i % 3] + 1e-3 : lo[i % 3] - 1e-3;
    EXPECT_TRUE(loc.locate(pm, y, -1).outside_hull) << i;
  }
}

TEST(KelvinLocator, GradedMeshAgreesWithTheScan) {
  // The wrench's graded mesh: the two-level grid adapts to both ends of its cell sizes.
  const Field& f = wrench_field();
  const TetMesh& m = f.tet_mesh();
  const Located located(m);
  const Locator& loc = located.locator;
  const PackedMesh& pm = located.packed;
  std::mt19937 rng(13);
  std::uniform_real_distribution<double> u(-0.12, 0.12);
  int inside = 0;
  for (int i = 0; i < 1500; ++i) {
    const Vec3 x(u(rng), u(rng), u(rng));
    inside += expect_agrees_with_scan(m, pm, loc, x / x.squaredNorm(), i);
  }
  EXPECT_GT(inside, 1000);
}

TEST(KelvinLocator, HintlessQueriesEqualHintedQueriesAndTheScanBitForBit) {
  // h and ∇h at random exterior points: the seeded location, a walk from the scan's cell, and h
  // interpolated by hand from the vertex values in the scan's cell. A point clearly inside one
  // cell is answered from that cell whatever the route, so the answers are identical bit for bit
  // (the seeding grid, the walk's prefetches and the packed (V, ∇V) records change no number).
  // On a shared face the cells may differ: then the field is continuous to rounding.
  Field f = Field::prepare(sphere_mesh(Sphere{}), sphere_options(0.1));
  f.set_sigma(constant_sigma(0.3));
  const TetMesh& m = f.tet_mesh();
  int interior = 0;
  for (const Vec3& x : shell_points(Sphere{}, 1.02, 8.0, 2000, 11)) {
    const Vec3 p = x - f.centre();
    const Vec3 y = p / p.squaredNorm();
    const Location s = scan_tet_mesh(m, y);
    int hint = s.cell;
    const Sample a = f.query(x), b = f.query(x, &hint);
    ASSERT_EQ(a.status, Status::ok);
    ASSERT_EQ(b.status, Status::ok);
    if (min_lambda(m, s.cell, y) > 1e-9 && m.in_domain[static_cast<size_t>(s.cell)]) {
      ++interior;
      EXPECT_EQ(hint, s.cell);
      double v = 0;  // same sum, same order as the query's interpolation
      for (int k = 0; k < 4; ++k) v += s.lambda[k] * f.vertex_values()[m.tets(s.cell, k)];
      EXPECT_EQ(a.h, -std::log(std::sqrt(y.squaredNorm()) * v));
      EXPECT_EQ(a.h, b.h);
      for (int k = 0; k < 3; ++k) EXPECT_EQ(a.gradient[k], b.gradient[k]);
    } else {
      EXPECT_NEAR(a.h, b.h, 1e-12 * std::max(1.0, std::abs(a.h)));
      EXPECT_LT((a.gradient - b.gradient).norm(), 1e-10 * b.gradient.norm());
    }
  }
  EXPECT_GT(interior, 1900);
  // Without gradients (set_sigma(…, false): no (V, ∇V) records) h is the same, ∇h NaN.
  std::vector<Vec3> xs = shell_points(Sphere{}, 1.02, 8.0, 300, 12);
  const std::vector<Sample> with = f.query(xs);
  f.set_sigma(constant_sigma(0.3), false);
  const std::vector<Sample> without = f.query(xs);
  for (size_t i = 0; i < xs.size(); ++i) {
    EXPECT_EQ(with[i].h, without[i].h) << i;
    EXPECT_TRUE(std::isnan(without[i].gradient.x())) << i;
  }
}

TEST(KelvinLocator, SeededWalksAreShort) {
  // The seeding grid's purpose: a hint-less walk starts in or next to the point's cell. Each step
  // is a chain of cache misses on large meshes, so the mean step count is the query's cost.
  const TetMesh& m = field().tet_mesh();
  const Located located(m);
  const Locator& loc = located.locator;
  const PackedMesh& pm = located.packed;
  const Vec3 lo = m.points.colwise().minCoeff().transpose(), hi = m.points.colwise().maxCoeff().transpose();
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0, 1);
  long steps = 0, n = 0, longest = 0;
  for (int i = 0; i < 5000; ++i) {
    const Vec3 y = lo + (hi - lo).cwiseProduct(Vec3(u(rng), u(rng), u(rng)));
    const Location l = loc.locate(pm, y, -1);
    if (l.outside_hull) continue;
    steps += l.steps;
    longest = std::max<long>(longest, l.steps);
    ++n;
  }
  ASSERT_GT(n, 2000);
  const double mean = static_cast<double>(steps) / static_cast<double>(n);
  std::printf("seeded walks: %.3f steps on average, longest %ld (%ld points)\n", mean, longest, n);
  EXPECT_LT(mean, kMaxMeanSeededSteps);
  EXPECT_LT(longest, 20);
}

TEST(KelvinLocator, BoundaryVerticesQueriedFromAnOutsideCellGiveSigma) {
  // Walking with a hint in a cell outside Ω_inv that touches a boundary vertex ends in that cell
  // (the point is on its closure); the query must still use a domain cell around the vertex:
  // h = σ there (eq. 9). Regression: a search of face neighbours alone missed them on the wrench.
  // The wrench: non-convex, so its triangulation has cells outside Ω_inv (the sphere has none).
  const Field f = wrench(0.006);
  const TetMesh& m = f.tet_mesh();
  int checked = 0;
  for (int c = 0; c < m.tets.rows(); ++c) {
    if (m.in_domain[static_cast<size_t>(c)]) continue;
    for (int k = 0; k < 4; ++k) {
      const int v = m.tets(c, k);
      if (!std::isfinite(f.vertex_values()[v])) continue;  // not a vertex of the domain
      const Vec3 y = m.points.row(v);
      int hint = c;
      const Sample s = f.query(f.centre() + y / y.squaredNorm(), &hint);
      ASSERT_EQ(s.status, Status::ok) << c;
      EXPECT_NEAR(s.h, 0.3, 1e-9) << c;
      ++checked;
    }
  }
  EXPECT_GT(checked, 500);
}

TEST(KelvinLocator, PackedWalksEqualAPlainWalkOverTheTetMeshBitForBit) {
  // The query's layout (packed cell records, the seeding grid's copies of their vertex ids, vertex
  // records with V and ∇V, prefetches) changes no number: from the same start cell the walk
  // ends in the same cell after the same steps with the same barycentric coordinates as a plain
  // walk over TetMesh, and h is the one interpolated by hand from the public vertex values.
  // Points: random in and beyond the triangulation's box (outside the hull), random far hints,
  // and points within rounding of faces, edges and vertices (the walk's tolerance decides there).
  Field& f = wrench_field();
  const TetMesh& m = f.tet_mesh();
  const Located located(m);
  const Locator& loc = located.locator;
  const PackedMesh& pm = located.packed;
  const Vec3 lo = m.points.colwise().minCoeff().transpose(), hi = m.points.colwise().maxCoeff().transpose();
  std::mt19937 rng(23);
  std::uniform_real_distribution<double> u(0, 1), tiny(-1e-13, 1e-13);
  std::uniform_int_distribution<int> cell(0, static_cast<int>(m.tets.rows()) - 1), corner(0, 3);
  std::vector<Vec3> ys;
  for (int i = 0; i < 3000; ++i) ys.emplace_back(lo + (hi - lo).cwiseProduct(Vec3(u(rng), u(rng), u(rng)) * 1.2 - Vec3::Constant(0.1)));
  for (int i = 0; i < 3000; ++i) {
    const int c = cell(rng);
    const Vec3 a = m.points.row(m.tets(c, corner(rng))), b = m.points.row(m.tets(c, corner(rng))),
               d = m.points.row(m.tets(c, corner(rng)));
    const Vec3 on = i % 3 == 0 ? a : i % 3 == 1 ? Vec3(0.5 * (a + b))
                                                : Vec3((a + b + d) / 3.0);
    ys.emplace_back(on + on.norm() * Vec3(tiny(rng), tiny(rng), tiny(rng)));
  }
  int outside = 0, not_domain = 0, stepped = 0, answered = 0;
  for (int i = 0; i < static_cast<int>(ys.size()); ++i) {
    // The point as the query computes it from its x (eq. 5 there and back, rounded).
    const Vec3 x = f.centre() + ys[static_cast<size_t>(i)] / ys[static_cast<size_t>(i)].squaredNorm();
    const Vec3 y = (x - f.centre()) / (x - f.centre()).squaredNorm();
    if (!y.allFinite()) continue;
    const int start = cell(rng);
    const Location ref_seeded = reference_walk(m, y, loc.seed(y)), ref_hinted = reference_walk(m, y, start);
    ASSERT_GE(ref_seeded.cell, 0) << i;
    ASSERT_GE(ref_hinted.cell, 0) << i;
    const Location seeded = loc.locate(pm, y, -1), hinted = loc.locate(pm, y, start);
    expect_same_location(seeded, ref_seeded, i);
    expect_same_location(hinted, ref_hinted, i);
    const bool in_domain = !ref_seeded.outside_hull && m.in_domain[static_cast<size_t>(ref_seeded.cell)];
    outside += ref_seeded.outside_hull;
    not_domain += !ref_seeded.outside_hull && !in_domain;
    stepped += ref_seeded.steps > 0;
    // The field's own query (its locator is built the same way) answers from the same cell.
    if (!in_domain) continue;
    int hint = start;
    const Sample a = f.query(x), b = f.query(x, &hint);
    double v = 0;  // the query's interpolation: same sum, same order
    for (int k = 0; k < 4; ++k) v += ref_seeded.lambda[k] * f.vertex_values()[m.tets(ref_seeded.cell, k)];
    if (!(v > 0)) continue;
    ++answered;
    ASSERT_EQ(a.status, Status::ok) << i;
    EXPECT_EQ(a.h, -std::log(std::sqrt(y.squaredNorm()) * v)) << i;
    if (ref_hinted.cell == ref_seeded.cell) {
      EXPECT_EQ(hint, ref_hinted.cell) << i;
      EXPECT_EQ(b.h, a.h) << i;
      for (int k = 0; k < 3; ++k) EXPECT_EQ(b.gradient[k], a.gradient[k]) << i;
    }
  }
  std::printf("off the hull %d, outside Ω_inv %d, stepped %d, answered %d\n", outside, not_domain, stepped, answered);
  // Each kind of point was met: off the hull, in cells outside Ω_inv, after face crossings.
  EXPECT_GT(outside, 100);
  EXPECT_GT(not_domain, 20);
  EXPECT_GT(stepped, 1000);
  EXPECT_GT(answered, 2000);
}

TEST(KelvinLocator, AHintChangesNoAnswerOnOrNearTheInputSurface) {
  // Points on the input surface fall in the sliver between it and the mesher's flat boundary:
  // off the hull or in cells outside Ω_inv, where the answer is taken from a domain cell near the
  // located one. The hint (a previous query's cell) may change where the walk ends there, but not
  // the answer: h, ∇h and status as a query without a hint gives, for any hint. Regression: on a
  // scanned bunny, h on its own vertices differed by 0.09 between query orders.
  Field& f = wrench_field();
  const mesh::SurfaceMesh s = mesh::weld(mesh::load_mesh(std::string(DISTLAB_ASSET_DIR) + "/wrench.stl")).surface;
  std::vector<Vec3> xs;
  for (int v = 0; v < s.vertices.rows(); ++v) xs.emplace_back(s.vertices.row(v).transpose());
  for (int t = 0; t < s.faces.rows(); ++t) {
    Vec3 c = Vec3::Zero();
    for (int k = 0; k < 3; ++k) c += s.vertices.row(s.faces(t, k)).transpose() / 3.0;
    xs.push_back(c);
  }
  std::mt19937 rng(29);
  std::uniform_int_distribution<int> cell(0, static_cast<int>(f.tet_mesh().tets.rows()) - 1);
  int ok = 0, differing_cells = 0;
  double worst_sigma = 0;  // |h − σ| on the surface
  int previous = -1;       // hints in the order of the points, as a coherent batch query uses them
  for (std::size_t i = 0; i < xs.size(); ++i) {
    const Sample alone = f.query(xs[i]);
    for (int round = 0; round < 2; ++round) {
      int hint = round == 0 ? previous : cell(rng);
      const Sample hinted = f.query(xs[i], &hint);
      if (round == 0) previous = hint;
      ASSERT_EQ(hinted.status, alone.status) << i << " round " << round;
      if (alone.status != Status::ok) continue;
      ++ok;
      worst_sigma = std::max(worst_sigma, std::abs(alone.h - 0.3));
      // Both in domain cells but different ones (a point on their shared face): equal to rounding.
      const Sample again = f.query(xs[i]);
      ASSERT_EQ(again.h, alone.h) << i;
      if (hinted.h != alone.h) ++differing_cells;
      ASSERT_NEAR(hinted.h, alone.h, 1e-12 * (1 + std::abs(alone.h))) << i << " round " << round;
      for (int k = 0; k < 3; ++k)
        ASSERT_NEAR(hinted.gradient[k], alone.gradient[k], 1e-9 * (1 + alone.gradient.norm())) << i << " round " << round;
    }
  }
  std::printf("surface points %zu, answered %d, on a face between two domain cells %d, |h - sigma| <= %.3g\n", xs.size(), ok,
              differing_cells, worst_sigma);
  // Every point of the surface is answered (none INSIDE by rounding), twice each.
  EXPECT_EQ(ok, 2 * static_cast<int>(xs.size()));
}
