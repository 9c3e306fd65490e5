#include "distlab/cbf/rows.hpp"

#include <cmath>

namespace distlab::cbf {

int joint_limit_rows(const Robot& robot) {
  int n = 0;
  for (int i = 0; i < robot.dof(); ++i) n += std::isfinite(robot.q_min()[i]) + std::isfinite(robot.q_max()[i]);
  return n;
}

void cbf_rows(const Robot& robot, std::span<const robot::RobotPair> pairs, const VecQ& q,
              std::span<const robot::PairDistance> distances, const GradQ& grad, const RowParams& params,
              Eigen::MatrixXd& C, Eigen::VectorXd& d, const FieldRows& fields) {
  const int np = static_cast<int>(pairs.size());
  const int nf = static_cast<int>(fields.samples.size());
  const int dof = robot.dof();
  const int rows = np + nf + joint_limit_rows(robot);
  C.resize(rows, dof);
  d.resize(rows);
  for (int p = 0; p < np; ++p) {
    const double delta = pairs[p].self ? params.margins.self : params.margins.obstacle;
    C.row(p) = grad.row(p);
    d[p] = -params.eta * (distances[p].distance - delta);
  }
  for (int f = 0; f < nf; ++f) {
    C.row(np + f) = fields.grad->row(f);
    d[np + f] = -params.eta * (fields.samples[f].h - fields.margins[f]);
  }
  C.bottomRows(rows - np - nf).setZero();
  int r = np + nf;
  for (int i = 0; i < dof; ++i)
    if (std::isfinite(robot.q_min()[i])) {
      C(r, i) = 1;
      d[r++] = -params.eta_joint * (q[i] - robot.q_min()[i]);
    }
  for (int i = 0; i < dof; ++i)
    if (std::isfinite(robot.q_max()[i])) {
      C(r, i) = -1;
      d[r++] = -params.eta_joint * (robot.q_max()[i] - q[i]);
    }
}

}  // namespace distlab::cbf
