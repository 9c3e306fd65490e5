#pragma once
// The CBF rows of the QP (gap-differentiable-distance.txt eq. 7, franka-corridor.md): for a
// caller's own controller (Robot::cbf_rows in Python) and the built-in CbfController alike.
#include <span>
#include <vector>

#include <Eigen/Core>

#include "distlab/cbf/scenario.hpp"

namespace distlab::cbf {

struct RowParams {
  Margins margins{0.002, 0.0001};  // δ of obstacle and self pairs (the scenario's, per metric)
  double eta = 0.5;                // η of the distance rows
  double eta_joint = 0.5;          // η_q of the joint-limit rows
};

// The rows of Kelvin fields (fields.hpp, FieldBarrier::evaluate): h, ∇_q h and δ per row.
struct FieldRows {
  std::span<const FieldPointSample> samples;
  const Eigen::MatrixXd* grad = nullptr;  // rows × dof
  std::span<const double> margins;        // δ per row
};

// The rows C u ≥ d at q, u the joint velocity:
//   row p < P:  ∇_q D_p · u ≥ −η (D_p − δ)       (δ = margins.self for a self pair, else .obstacle)
//   then field row r < R (fields.samples): ∇_q h_r · u ≥ −η (h_r − δ_r), every sample's status ok
//   then, per joint i with a finite lower limit (joint order):   u_i ≥ −η_q (q_i − q_min,i)
//   then, per joint i with a finite upper limit:                −u_i ≥ −η_q (q_max,i − q_i)
// (continuous joints have neither). grad row p is ∇_q D_p (DistanceModel::evaluate).
void cbf_rows(const Robot& robot, std::span<const robot::RobotPair> pairs, const VecQ& q,
              std::span<const robot::PairDistance> distances, const GradQ& grad, const RowParams& params,
              Eigen::MatrixXd& C, Eigen::VectorXd& d, const FieldRows& fields = {});

// The number of joint-limit rows cbf_rows appends (finite limits of both sides).
int joint_limit_rows(const Robot& robot);

}  // namespace distlab::cbf
