#include "distlab/cbf/controller.hpp"

#include <chrono>
#include <cmath>
#include <limits>

#include "distlab/collision/euclidean.hpp"
#include "distlab/gap/solver.hpp"

namespace distlab::cbf {
namespace {

using Clock = std::chrono::steady_clock;
double us_since(Clock::time_point t0, Clock::time_point t1) {
  return std::chrono::duration<double, std::micro>(t1 - t0).count();
}
Mat3 skew(const Vec3& v) {
  Mat3 S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

}  // namespace

// The published package's P2S construction (franka-corridor.md, last section): box half-spaces
// with weight 1, round shapes' terms with weight 1, polytope rows 1/(⌊N/2⌋ + 1), and the ρ ball
// centred on the bounding box with R² = 1.2 × (its half diagonal)².
P2SOptions published_options(const Shape& shape) {
  P2SOptions o;
  Vec3 lo, hi;
  if (const auto* box = std::get_if<Box>(&shape)) {
    o.weights = VecX::Ones(6);
    hi = box->size / 2;
    lo = -hi;
  } else if (const auto* poly = std::get_if<Polytope>(&shape)) {
    // NOLINTNEXTLINE(bugprone-integer-division): ⌊N/2⌋ is the package's rule
    o.weights = VecX::Constant(poly->A.rows(), 1.0 / (static_cast<double>(poly->A.rows() / 2) + 1));
    lo = hi = poly->vertices.front();
    for (const Vec3& v : poly->vertices) {
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
  } else {
    o.round_weight = 1.0;
    double r = 0, half_z = 0;
    if (const auto* c = std::get_if<Cylinder>(&shape)) r = c->radius, half_z = c->height / 2;
    if (const auto* c = std::get_if<Capsule>(&shape)) r = c->radius, half_z = c->height / 2 + c->radius;
    if (const auto* c = std::get_if<Sphere>(&shape)) r = half_z = c->radius;
    hi = Vec3(r, r, half_z);
    lo = -hi;
  }
  const double half_diagonal2 = ((hi - lo) / 2).squaredNorm();
  o.rho = Ball{(lo + hi) / 2, std::sqrt(1.2 * half_diagonal2)};
  return o;
}

// The published distance (gap.mode as_published): plain iteration (eq. 2) from B's centre,
// stopped at the first step below tol or after max_iter; D = sqrt(max(d_AB² + d_BA² − ‖a − b‖², 0))
// = sqrt(max(2Λ, 0)) at that iterate (d_AB² = 2 E_B(a), d_BA² = 2 E_A(b)); its gradient by the
// envelope formulas at the same iterate (dD = dΛ / D).
GapResult published_distance(const GapBody& A, const GapBody& B, const GapParams& params) {
  const Vec3 centre_b = B.pose().position + B.pose().R() * B.p2s().rho_ball().center;
  const WitnessSolution w = solve_fixed_point(A.p2s(), B.p2s(), centre_b, params.tol, params.max_iter);
  GapResult g;
  g.lambda = w.lambda;
  g.distance = std::sqrt(std::max(2.0 * w.lambda, 0.0));
  g.witness_a = w.a;
  g.witness_b = w.b;
  g.iterations = w.iterations;
  g.converged = w.converged;
  if (g.distance > 0) {
    lambda_gradients(w, A.pose(), B.pose(), g.gradient_a, g.gradient_b);
    g.gradient_a /= g.distance;
    g.gradient_b /= g.distance;
  }
  return g;
}

Task task_function(const Kinematics& k, const Robot& robot, const Pose& target) {
  const Jac Je = robot.ee_jacobian(k);
  const Mat3 Rd = target.R();
  Task t;
  t.J.resize(6, Je.cols());
  t.r.head<3>() = k.ee.position - target.position;
  t.J.topRows<3>() = Je.topRows<3>();
  for (int i = 0; i < 3; ++i) {
    const Vec3 axis = k.ee_R.col(i), axis_d = Rd.col(i);
    // r_i = max(0, 1 − a_dᵀa); d/dt = a_dᵀ S(a) ω (a_dᵀa ≤ 1 for unit axes, so the max is only
    // a kink at r_i = 0, where both one-sided rows are valid).
    t.r[3 + i] = std::max(0.0, 1.0 - axis_d.dot(axis));
    t.J.row(3 + i) = axis_d.transpose() * skew(axis) * Je.bottomRows<3>();
  }
  return t;
}

namespace {

// H = J_rᵀJ_r + λI, f = J_rᵀ K r. Fixed-size products for 6 and 7 joints: faster, and Eigen sums
// them in another order than its dynamic-size kernels, so a 7-joint arm keeps the records of the
// fixed-size code that came before robots as data (tests/cbf/test_record_regression.cpp).
template <int N>
void objective_n(const Task& t, double damping, double gain, Eigen::MatrixXd& H, Eigen::VectorXd& f) {
  const Eigen::Matrix<double, 6, N> J = t.J;
  H = J.transpose() * J + damping * Eigen::MatrixXd::Identity(J.cols(), J.cols());
  f = J.transpose() * (gain * t.r);
}
void task_objective(const Task& t, double damping, double gain, Eigen::MatrixXd& H, Eigen::VectorXd& f) {
  switch (t.J.cols()) {
    case 7:
      return objective_n<7>(t, damping, gain, H, f);
    case 6:
      return objective_n<6>(t, damping, gain, H, f);
    default:
      return objective_n<Eigen::Dynamic>(t, damping, gain, H, f);
  }
}

}  // namespace

struct CbfController::Impl {
  std::unique_ptr<robot::DistanceModel> model;
  robot::DistanceModel::Workspace w;      // FK, the robot's bodies and every pair's track, reused every step
  robot::DistanceModel::Adjust adjust;    // as_published: the early-stopped distance
  std::unique_ptr<FieldBarrier> barrier;  // the scenario's fields, if any
  std::vector<double> field_margins;      // δ per field row
  Eigen::MatrixXd field_grad;
  QpSolver qp;
  Eigen::MatrixXd H, C, C_relaxed, H_relaxed;
  Eigen::VectorXd f, d, f_relaxed, d_relaxed;
  GradQ grad;
};

CbfController::CbfController(const Scenario& scenario, Metric metric, const std::function<void()>& checkpoint)
    : scenario_(scenario), metric_(metric), impl_(std::make_unique<Impl>()) {
  validate(scenario_);
  robot_ = scenario_.robot;
  Impl& m = *impl_;
  const bool published = scenario_.gap_mode == GapMode::as_published;
  // as_published: the Newton reference (converged D) runs on the published functions too.
  GapParams exact = scenario_.gap;
  robot::DistanceModel::BodyOptions options;
  if (published) {
    exact.solver = GapSolver::newton;
    exact.tol = 1e-10;
    exact.max_iter = 0;
    options = [](const Shape& shape, const P2SOptions&) { return published_options(shape); };
    m.adjust = [this](int, const GapBody& A, const GapBody& B, GapResult& g, PairSample& s) {
      s.converged_distance = g.distance;
      const bool overlap = g.overlap;
      g = published_distance(A, B, scenario_.gap);
      g.overlap = overlap;
    };
  }
  robot::PairSelection selection;
  selection.self = scenario_.self_collision;
  m.model = std::make_unique<robot::DistanceModel>(robot_, scenario_.obstacles, metric_, exact, selection, options,
                                                   checkpoint);
  m.w = m.model->workspace();
  if (!scenario_.fields.empty()) {
    m.barrier = std::make_unique<FieldBarrier>(scenario_.fields, scenario_.control_points);
    for (const SceneField& f : scenario_.fields) m.field_margins.insert(m.field_margins.end(), scenario_.control_points.size(), f.margin);
  }
}

CbfController::~CbfController() = default;

const std::vector<PairInfo>& CbfController::pairs() const { return impl_->model->pairs(); }
const robot::DistanceModel& CbfController::model() const { return *impl_->model; }
const FieldBarrier* CbfController::barrier() const { return impl_->barrier.get(); }
int CbfController::field_rows() const { return impl_->barrier ? impl_->barrier->rows() : 0; }

void CbfController::reset_warm_start() {
  impl_->w.tracks.assign(pairs().size(), GapTrack{});
  if (impl_->barrier) impl_->barrier->reset_hints();
}

// h and ∇_q h at every control point (at impl_'s kinematics); throws FieldUndefined.
static FieldRows field_rows_at(FieldBarrier* barrier, const Robot& robot, const Kinematics& k,
                               std::vector<FieldPointSample>& samples, Eigen::MatrixXd& grad,
                               const std::vector<double>& margins) {
  if (!barrier) return {};
  barrier->evaluate(robot, k, samples, grad);
  require_defined(samples, barrier->fields(), barrier->points());
  return {samples, &grad, margins};
}

void CbfController::distances(const VecQ& q, std::vector<PairSample>& samples, GradQ& grad) {
  robot_->forward(q, impl_->w.kinematics);
  compute_pairs(samples, grad);
}

void CbfController::compute_pairs(std::vector<PairSample>& samples, GradQ& grad) {
  samples.resize(pairs().size());
  impl_->model->evaluate_at(impl_->w, true, samples, grad, impl_->adjust);
}

static RowParams row_params(const Scenario& s, Metric metric) { return {s.margins(metric), s.eta, s.eta_joint}; }

void CbfController::rows(const VecQ& q, Eigen::MatrixXd& C, Eigen::VectorXd& d) {
  std::vector<PairSample> samples;
  std::vector<FieldPointSample> field_samples;
  distances(q, samples, impl_->grad);
  const FieldRows fields = field_rows_at(impl_->barrier.get(), *robot_, impl_->w.kinematics, field_samples,
                                         impl_->field_grad, impl_->field_margins);
  cbf_rows(*robot_, pairs(), q, samples, impl_->grad, row_params(scenario_, metric_), C, d, fields);
}

StepOutput CbfController::step(const VecQ& q, bool audit) {
  Impl& m = *impl_;
  StepOutput out;
  out.u = VecQ::Zero(robot_->dof());
  const auto t0 = Clock::now();
  const Robot& robot = *robot_;
  const int dof = robot.dof();
  Kinematics& k = m.w.kinematics;
  robot.forward(q, k);
  const Task task = task_function(k, robot, scenario_.target);
  const auto t1 = Clock::now();
  compute_pairs(out.pairs, m.grad);
  const auto tf = Clock::now();
  const FieldRows fields = field_rows_at(m.barrier.get(), robot, k, out.field_points, m.field_grad, m.field_margins);
  const auto t2 = Clock::now();

  // Rows C u ≥ d: eq. (7) for every pair, the fields' rows, then the joint limits (every joint
  // is bounded: validate).
  const int np = static_cast<int>(pairs().size()) + field_rows();
  cbf_rows(robot, pairs(), q, out.pairs, m.grad, row_params(scenario_, metric_), m.C, m.d, fields);
  const int rows = static_cast<int>(m.C.rows());
  task_objective(task, scenario_.damping, scenario_.task_gain, m.H, m.f);
  QpResult res = m.qp.solve(m.H, m.f, m.C, m.d);
  out.status = res.status;
  if (res.status == QpStatus::optimal) {
    out.u = res.x;
  } else {
    // Infeasible (or stalled): relax every distance row by one slack s ≥ 0 with cost ½ w s².
    // Always feasible: the joint-limit rows alone are (q_min < q_max), and s absorbs the rest.
    out.relaxed = true;
    m.H_relaxed = Eigen::MatrixXd::Zero(dof + 1, dof + 1);
    m.H_relaxed.topLeftCorner(dof, dof) = m.H;
    m.H_relaxed(dof, dof) = scenario_.slack_weight;
    m.f_relaxed = Eigen::VectorXd::Zero(dof + 1);
    m.f_relaxed.head(dof) = m.f;
    m.C_relaxed = Eigen::MatrixXd::Zero(rows + 1, dof + 1);
    m.C_relaxed.topLeftCorner(rows, dof) = m.C;
    m.C_relaxed.col(dof).head(np).setOnes();
    m.C_relaxed(rows, dof) = 1;
    m.d_relaxed.resize(rows + 1);
    m.d_relaxed.head(rows) = m.d;
    m.d_relaxed[rows] = 0;
    res = m.qp.solve(m.H_relaxed, m.f_relaxed, m.C_relaxed, m.d_relaxed);
    if (res.status == QpStatus::optimal) {
      out.u = res.x.head(dof);
      out.slack = res.x[dof];
    } else {
      out.held = true;  // u stays 0
    }
  }
  out.active_rows = static_cast<int>(res.active.size());
  for (int row : res.active)
    if (row < rows) {  // not the relaxation's s ≥ 0
      out.active.push_back(row);
      out.multiplier.push_back(res.lambda[row]);
    }
  if (scenario_.velocity_limit.size() == dof &&
      !(scenario_.velocity_limit.array() == std::numeric_limits<double>::infinity()).all()) {
    // Clipped per joint, as the robot's interface does (franka-corridor.md, the real-robot run).
    const VecQ clipped = out.u.cwiseMax(-scenario_.velocity_limit).cwiseMin(scenario_.velocity_limit);
    out.clipped = clipped != out.u;
    out.u = clipped;
  }
  const auto t3 = Clock::now();

  out.r = task.r;
  out.task_error = task.r.norm();
  out.timing.kinematics = us_since(t0, t1);
  out.timing.distance = us_since(t1, tf);
  out.timing.field = us_since(tf, t2);
  out.timing.qp = us_since(t2, t3);
  out.timing.step = us_since(t0, t3);

  out.min_clearance = std::numeric_limits<double>::infinity();
  if (audit) {
    const auto a0 = Clock::now();
    for (int p = 0; p < static_cast<int>(out.pairs.size()); ++p) {
      PairSample& s = out.pairs[p];
      if (std::isnan(s.clearance)) {
        const PairInfo& pair = pairs()[p];
        const robot::DistanceModel& model = *m.model;
        const Pose& pb = pair.self ? m.w.robot_pose[pair.b] : model.obstacles()[pair.b].pose;
        const EuclideanShape& eb = pair.self ? model.robot_shape(pair.b) : model.obstacle_shape(pair.b);
        s.clearance = euclidean_distance(model.robot_shape(pair.a), m.w.robot_pose[pair.a], eb, pb).distance;
      }
      out.min_clearance = std::min(out.min_clearance, s.clearance);
    }
    out.timing.audit = us_since(a0, Clock::now());
  } else {
    out.min_clearance = std::numeric_limits<double>::quiet_NaN();
  }
  return out;
}

}  // namespace distlab::cbf
