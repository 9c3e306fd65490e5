// Stochastic visibility walk (terminates on Delaunay/regular triangulations) and seeding grid.
#include "locator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

namespace distlab::kelvin {

Location walk(const PackedMesh& m, const Vec3& y, int c, const int* first_vertices = nullptr);

void barycentric(const TetMesh& m, int c, const Vec3& y, double lambda[4]) {
  const auto* t = m.tets.row(c).data();
  const auto p = [&](int k) { return m.points.row(t[k]).data(); };
  barycentric(p(0), p(1), p(2), p(3), y, lambda);
}

namespace {

// Coarse blocks hold about this many cells each; a block with n cells is split into r³ boxes with
// r = round(∛(kBoxesPerCell · n)), so the grid has about kBoxesPerCell boxes per cell in total.
constexpr double kCellsPerBlock = 16;
constexpr double kBoxesPerCell = 1;
constexpr int kMaxBlocksPerAxis = 512, kMaxBoxesPerAxis = 32;

// Grid coordinate (in blocks) of y along axis k, clamped into the grid; NaN maps to 0.
double grid_coordinate(double y, double lo, double inv_step, int n) {
  const double f = (y - lo) * inv_step, top = std::nextafter(static_cast<double>(n), 0.0);
  return f > 0 ? (f < top ? f : top) : 0.0;
}

}  // namespace

void Locator::build(const PackedMesh& m) {
  blocks_.clear();
  cells_.clear();
  seed_vertices_.clear();
  const long n_cells = static_cast<long>(m.cells.size());
  if (n_cells == 0) return;
  lo_ = Vec3::Constant(std::numeric_limits<double>::infinity());
  Vec3 hi = -lo_;
  for (const VertexRecord& v : m.vertices) {
    lo_ = lo_.cwiseMin(Eigen::Map<const Vec3>(v.y));
    hi = hi.cwiseMax(Eigen::Map<const Vec3>(v.y));
  }
  const Vec3 extent = (hi - lo_).cwiseMax(1e-12);
  const double block = std::cbrt(extent.prod() * kCellsPerBlock / static_cast<double>(n_cells));
  for (int k = 0; k < 3; ++k) {
    n_[k] = std::clamp(static_cast<int>(std::ceil(extent[k] / block)), 1, kMaxBlocksPerAxis);
    inv_step_[k] = n_[k] / extent[k];
  }
  const size_t n_blocks = static_cast<size_t>(n_[0]) * n_[1] * n_[2];
  auto block_of = [&](const double f[3]) {
    return (static_cast<size_t>(f[2]) * n_[1] + static_cast<size_t>(f[1])) * n_[0] + static_cast<size_t>(f[0]);
  };

  // Cells per block (by centroid) → boxes per block.
  std::vector<std::uint32_t> count(n_blocks, 0);
  for (long c = 0; c < n_cells; ++c) {
    const int* t = m.cells[static_cast<size_t>(c)].v;
    const auto p = [&](int k) { return Vec3(Eigen::Map<const Vec3>(m.vertices[static_cast<size_t>(t[k])].y)); };
    const Vec3 centroid = 0.25 * (p(0) + p(1) + p(2) + p(3));
    double f[3];
    for (int k = 0; k < 3; ++k) f[k] = grid_coordinate(centroid[k], lo_[k], inv_step_[k], n_[k]);
    ++count[block_of(f)];
  }
  blocks_.resize(n_blocks);
  std::size_t total = 0;
  for (size_t b = 0; b < n_blocks; ++b) {
    const auto r = static_cast<std::uint32_t>(
        std::clamp(std::lround(std::cbrt(kBoxesPerCell * count[b])), 1L, static_cast<long>(kMaxBoxesPerAxis)));
    blocks_[b] = {static_cast<std::uint32_t>(total), r};
    total += static_cast<std::size_t>(r) * r * r;
    if (total > static_cast<std::size_t>(std::numeric_limits<int>::max()))
      throw std::length_error("seeding grid: too many boxes");
  }
  cells_.assign(total, -1);

  // Each box holds the cell containing its centre, found by a walk from the previous box's cell
  // (adjacent boxes: a step or two; cheaper than rasterizing the cells over the box centres, which
  // measured 3x slower). A centre off the hull keeps the hull cell where the walk stopped.
  int last = 0;
  for (size_t b = 0; b < n_blocks; ++b) {
    const int r = static_cast<int>(blocks_[b].r);
    const int idx[3] = {static_cast<int>(b % n_[0]), static_cast<int>(b / n_[0] % n_[1]), static_cast<int>(b / n_[0] / n_[1])};
    for (int s = 0; s < r * r * r; ++s) {
      int& cell = cells_[blocks_[b].first + static_cast<size_t>(s)];
      if (cell < 0) {
        const int sub[3] = {s % r, s / r % r, s / r / r};
        const int found = walk(m, centre(idx, sub, r), last).cell;
        cell = found >= 0 ? found : last;  // a cycling walk (rare) keeps its nearby start
      }
      last = cell;
    }
  }
  seed_vertices_.resize(total);
  for (size_t i = 0; i < total; ++i)
    std::copy_n(m.cells[static_cast<size_t>(cells_[i])].v, 4, seed_vertices_[i].begin());
}

Vec3 Locator::centre(const int idx[3], const int sub[3], int r) const {
  Vec3 y;
  for (int k = 0; k < 3; ++k) y[k] = lo_[k] + (idx[k] + (sub[k] + 0.5) / r) / inv_step_[k];
  return y;
}

Vec3 Locator::box_centre(std::size_t box) const {
  // The block holding box: the last block whose first box is ≤ box (blocks_ is sorted by first).
  const auto it = std::upper_bound(blocks_.begin(), blocks_.end(), box,
                                   [](std::size_t i, const Block& b) { return i < b.first; }) -
                  1;
  const size_t b = static_cast<size_t>(it - blocks_.begin());
  const int r = static_cast<int>(it->r);
  const size_t s = box - it->first;
  const int idx[3] = {static_cast<int>(b % n_[0]), static_cast<int>(b / n_[0] % n_[1]), static_cast<int>(b / n_[0] / n_[1])};
  const int sub[3] = {static_cast<int>(s % r), static_cast<int>(s / r % r), static_cast<int>(s / r / r)};
  return centre(idx, sub, r);
}

int Locator::seed(const Vec3& y) const { return cells_[box(y)]; }

std::size_t Locator::box(const Vec3& y) const {
  double f[3];
  for (int k = 0; k < 3; ++k) f[k] = grid_coordinate(y[k], lo_[k], inv_step_[k], n_[k]);
  const Block blk = blocks_[(static_cast<size_t>(f[2]) * n_[1] + static_cast<size_t>(f[1])) * n_[0] + static_cast<size_t>(f[0])];
  const double r = blk.r;
  int s[3];
  for (int k = 0; k < 3; ++k) s[k] = std::min(static_cast<int>((f[k] - std::floor(f[k])) * r), static_cast<int>(blk.r) - 1);
  return blk.first + (static_cast<size_t>(s[2]) * blk.r + s[1]) * blk.r + s[0];
}

Location Locator::locate(const PackedMesh& m, const Vec3& y, int start) const {
  Location loc;
  if (start >= 0 && static_cast<size_t>(start) < m.cells.size()) {
    loc = walk(m, y, start);
  } else {
    const std::size_t b = box(y);
    loc = walk(m, y, cells_[b], seed_vertices_[b].data());
  }
  // The walk cycled (seen at l_x = 0.03 on the cube: rounding in the barycentric coordinates of
  // nearly flat cells). Fall back to a scan of every cell: slow, rare, and it always ends.
  return loc.cell >= 0 ? loc : scan(m, y);
}

// True when no walk from c can end: every cell reachable from c through faces with λ < −eps
// (the only moves a walk makes) has such a face, and none of them is a hull face. Rounding in
// nearly flat hull cells makes such closed cycles (three cells at l_x = 0.03 on the cube); the
// walk would spin through its whole budget (4 · cells steps, ~1 s at 0.03) to give up. Only
// small sets are explored (a long but healthy walk reaches many cells): false when unsure.
static bool walk_is_trapped(const PackedMesh& m, const Vec3& y, int c, double eps) {
  constexpr int kMaxCells = 64;
  int seen[kMaxCells], n_seen = 1, next = 0;
  seen[0] = c;
  double lambda[4];
  while (next < n_seen) {
    const int t = seen[next++];
    barycentric(m, t, y, lambda);
    bool moves = false;
    for (int k = 0; k < 4; ++k) {
      if (!(lambda[k] < -eps)) continue;
      moves = true;
      const int n = m.cells[static_cast<size_t>(t)].n[k];
      if (n < 0) return false;
      if (std::find(seen, seen + n_seen, n) != seen + n_seen) continue;
      if (n_seen == kMaxCells) return false;
      seen[n_seen++] = n;
    }
    if (!moves) return false;
  }
  return true;
}

// Prefetches what the walk reads after c's vertices: the in-domain flag (read by the query if c
// is the last cell) and the records of c's face neighbours (one of them is the next cell), so
// they load in parallel with the vertices instead of after them.
static void prefetch_around(const PackedMesh& m, int c) {
  __builtin_prefetch(&m.in_domain[static_cast<std::size_t>(c)]);
  for (const int n : m.cells[static_cast<std::size_t>(c)].n)
    if (n >= 0) __builtin_prefetch(&m.cells[static_cast<std::size_t>(n)]);
}

// Stochastic visibility walk; cell -1 when it did not end within its step budget.
// first_vertices: c's vertex ids if the caller has them at hand (the seeding grid's copy).
Location walk(const PackedMesh& m, const Vec3& y, int c, const int* first_vertices) {
  Location loc;
  // Tolerance so a point on a shared face is accepted by either cell instead of ping-ponging.
  constexpr double eps = 1e-12;
  std::uint32_t rng = 2463534242u;
  const long max_steps = 4 * static_cast<long>(m.cells.size()) + 16;
  long check = 1024;  // long walks are checked for a trap at steps 1024, 4096, 16384, …
  for (long step = 0; step < max_steps; ++step) {
    if (step == check) {
      check *= 4;
      // Same outcome as spending the rest of the budget: cell -1.
      if (walk_is_trapped(m, y, c, eps)) break;
    }
    prefetch_around(m, c);
    barycentric(m, step == 0 && first_vertices ? first_vertices : m.cells[static_cast<size_t>(c)].v, y, loc.lambda);
    rng ^= rng << 13, rng ^= rng >> 17, rng ^= rng << 5;
    const int first = static_cast<int>(rng & 3u);
    int exit = -1;
    for (int k = 0; k < 4 && exit < 0; ++k) {
      const int i = (first + k) & 3;
      if (loc.lambda[i] < -eps) exit = i;
    }
    loc.cell = c;
    loc.steps = static_cast<int>(step);
    if (exit < 0) return loc;
    const int next = m.cells[static_cast<size_t>(c)].n[exit];
    if (next < 0) {
      loc.outside_hull = true;
      return loc;
    }
    c = next;
  }
  loc.cell = -1;
  return loc;
}

// Every cell, keeping the one the point is most inside of (largest smallest barycentric).
Location Locator::scan(const PackedMesh& m, const Vec3& y) {
  Location loc;
  double best = -std::numeric_limits<double>::infinity();
  double lambda[4];
  for (int k = 0; k < static_cast<int>(m.cells.size()); ++k) {
    barycentric(m, k, y, lambda);
    const double worst = std::min(std::min(lambda[0], lambda[1]), std::min(lambda[2], lambda[3]));
    if (std::isfinite(worst) && worst > best) {
      best = worst;
      loc.cell = k;
      std::copy(lambda, lambda + 4, loc.lambda);
    }
  }
  if (!(best >= -1e-9)) {
    // Not inside any finite cell: outside the hull; report the nearest cell as the walk does.
    loc.outside_hull = true;
  }
  return loc;
}

}  // namespace distlab::kelvin
