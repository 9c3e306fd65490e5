#include "boundary_response.hpp"

#include <algorithm>
#include <array>

#include "distlab/geometry/parallel.hpp"

namespace distlab::kelvin {

namespace {
// Columns per CHOLMOD solve: the factor is read once per block (matrix-matrix kernels), so the
// block is wide enough to make that cheap, and narrow enough that a cancel waits little.
constexpr long kBlockColumns = 64;
// Below this many entries applied, one thread (the fork costs more than it saves).
constexpr double kTwoThreadEntries = 1e6;
constexpr size_t kGroup = 8;  // columns read side by side per row pass
}  // namespace

double BoundaryResponse::megabytes(Eigen::Index n_interior, Eigen::Index n_boundary) {
  return 8e-6 * static_cast<double>(n_interior) * static_cast<double>(n_boundary);
}

double BoundaryResponse::megabytes() const {
  return 8e-6 * static_cast<double>(columns_.size());
}

double BoundaryResponse::bytes_read(std::size_t count) const {
  return 8.0 * static_cast<double>(rows_) * static_cast<double>(count);
}

void BoundaryResponse::clear() {
  columns_ = {};
  rows_ = 0;
}

void BoundaryResponse::build(const CholmodSolver& solver, const Eigen::SparseMatrix<double>& a_ob,
                             const Progress& progress) {
  clear();
  const Eigen::Index rows = a_ob.rows(), cols = a_ob.cols();
  std::vector<double> g(static_cast<size_t>(rows) * static_cast<size_t>(cols), 0.0);
  for (Eigen::Index c = 0; c < cols; ++c)  // −A_Ω∂ e_c (eq. 20)
    for (Eigen::SparseMatrix<double>::InnerIterator it(a_ob, c); it; ++it)
      g[static_cast<size_t>(c) * static_cast<size_t>(rows) + static_cast<size_t>(it.row())] = -it.value();
  progress("response", 0.0);
  solver.solve_columns(g.data(), static_cast<long>(cols), kBlockColumns, [&](double f) { progress("response", f); });  // eq. 21
  columns_ = std::move(g);
  rows_ = rows;
}

void BoundaryResponse::apply(const std::vector<std::pair<std::size_t, double>>& changes, VecX& out, int threads) const {
  const auto rows = static_cast<long>(rows_);
  auto column = [&](size_t i) { return columns_.data() + changes[i].first * static_cast<size_t>(rows_); };
  auto rows_from = [&](long r0, long r1) {
    double* o = out.data();
    size_t i = 0;
    for (; i + kGroup <= changes.size(); i += kGroup) {
      std::array<const double*, kGroup> c{};
      std::array<double, kGroup> d{};
      for (size_t q = 0; q < kGroup; ++q) c[q] = column(i + q), d[q] = changes[i + q].second;
      for (long r = r0; r < r1; ++r)
        o[r] += ((c[0][r] * d[0] + c[1][r] * d[1]) + (c[2][r] * d[2] + c[3][r] * d[3])) +
                ((c[4][r] * d[4] + c[5][r] * d[5]) + (c[6][r] * d[6] + c[7][r] * d[7]));
    }
    for (; i < changes.size(); ++i) {
      const double* c = column(i);
      const double d = changes[i].second;
      for (long r = r0; r < r1; ++r) o[r] += c[r] * d;
    }
  };
  const bool two = threads == 2 || (threads == 0 && static_cast<double>(rows) * static_cast<double>(changes.size()) >= kTwoThreadEntries);
  if (!two) {
    rows_from(0, rows);
    return;
  }
  const long half = rows / 2 / 8 * 8;  // a cache line apart
  parallel_for(2, 2, [&](size_t part) { part == 0 ? rows_from(0, half) : rows_from(half, rows); });
}

}  // namespace distlab::kelvin
