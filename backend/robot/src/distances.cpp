#include "distlab/robot/distances.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <mutex>
#include <thread>

#include "distlab/gap/validator.hpp"
#include "distlab/geometry/error.hpp"
#include "distlab/geometry/parallel.hpp"
#include "distlab/geometry/progress.hpp"

namespace distlab::robot {

const char* to_string(Metric m) { return m == Metric::gap ? "gap" : "euclidean"; }

P2SOptions gap_body_options(const Shape& shape, P2SOptions options, const GapParams& params) {
  if (!std::holds_alternative<Box>(shape) || options.weights) return options;
  P2SOptions box = options;
  box.weights = VecX::Constant(6, 1.0 / (1.0 + params.weight_margin));
  // Property 2 near the ρ sphere also depends on the box's proportions to h: the orthogonal-face
  // weight is kept only where the validator finds no eigenvalue ≥ 1 (verdicts are cached).
  const GapBody body(shape, Pose{}, params, box, "box");
  return validate_p2s(body.p2s()).ok ? box : options;
}

namespace {
// x rounded down to two significant digits (x > 0), computed with an exact power of ten so that
// the value printed with %.2g reads back as the same double.
double two_digits_down(double x) {
  const int e = static_cast<int>(std::floor(std::log10(x))) - 1;
  if (e < -22 || e > 22) return x;  // 10^|e| is exact only up to 1e22
  const double scale = std::pow(10.0, std::abs(e));
  return e < 0 ? std::max(std::floor(x * scale), 1.0) / scale : std::max(std::floor(x / scale), 1.0) * scale;
}
}  // namespace

GapParams element_params(const EuclideanShape& shape, const GapParams& params,
                         const std::function<P2SOptions(const GapParams&)>& options, std::string& note,
                         const std::function<void()>& checkpoint) {
  const double radius = bounding_ball(shape.shape()).radius;
  const bool small = radius < kSmallElementShare * params.h, large = radius >= kLargeElementShare * params.h;
  if (!small && !large) return params;
  GapParams own = params;
  double first_eigenvalue = 0, last_eigenvalue = 0;
  const int attempts = small ? kSmallElementAttempts : kLargeElementAttempts;
  for (int attempt = 0; attempt < attempts; ++attempt) {
    if (checkpoint) checkpoint();
    const GapBody body(shape, Pose{}, own, options(own), "element");
    const ValidationReport report = validate_p2s(body.p2s());
    if (report.ok) {
      if (attempt == 0) return params;
      char text[320];
      if (small)
        std::snprintf(text, sizeof text,
                      "bounding radius %.2g m, small against h = %.6g: its GAP function takes h = %.2g, where "
                      "Property 2 holds (at h = %.6g the Hessian's eigenvalue reaches %.3g); its distances are "
                      "sharper than the other elements'",
                      radius, params.h, own.h, params.h, first_eigenvalue);
      else
        std::snprintf(text, sizeof text,
                      "bounding radius %.3g m, large against h = %.6g: its GAP function takes eps = %.6g, where "
                      "Property 2 holds (at eps = %.6g the Hessian's eigenvalue reaches %.3g)",
                      radius, params.h, own.eps, params.eps, first_eigenvalue);
      note = text;
      return own;
    }
    // Only the growth that falls with h (small) or ε (large) is helped: a large element whose
    // eigenvalue did not fall with ε stops there.
    if (!(report.max_eigenvalue > 1) || !std::isfinite(report.max_eigenvalue)) break;
    if (large && attempt > 0 && !(report.max_eigenvalue < last_eigenvalue)) break;
    if (attempt == 0) first_eigenvalue = report.max_eigenvalue;
    last_eigenvalue = report.max_eigenvalue;
    if (small)
      own.h = two_digits_down(own.h * kSmallElementMargin / report.max_eigenvalue);
    else
      own.eps /= 2;
  }
  return params;  // still failing: the validation reports it at the given params
}

namespace {

// Self pairs of the selection: Robot::self_pairs, plus the allowed link pairs, less the denied.
std::vector<std::pair<int, int>> self_pairs(const Robot& robot, const PairSelection& s) {
  const auto links = [&](const std::vector<std::pair<std::string, std::string>>& list, const char* name) {
    std::vector<std::pair<int, int>> out;
    for (std::size_t i = 0; i < list.size(); ++i) {
      const std::string f = std::string("pairs.") + name + "[" + std::to_string(i) + "]";
      const int a = robot.link_index(list[i].first), b = robot.link_index(list[i].second);
      if (a < 0 || b < 0)
        throw InvalidInput(f, f + ": \"" + (a < 0 ? list[i].first : list[i].second).substr(0, 64) +
                                  "\" is not a link of the robot");
      out.emplace_back(std::min(a, b), std::max(a, b));
    }
    return out;
  };
  const auto allow = links(s.allow, "allow"), deny = links(s.deny, "deny");
  const auto listed = [](const std::vector<std::pair<int, int>>& list, int la, int lb) {
    return std::find(list.begin(), list.end(), std::make_pair(std::min(la, lb), std::max(la, lb))) != list.end();
  };
  const auto& prims = robot.primitives();
  std::vector<std::pair<int, int>> out;
  for (int i = 0; i < static_cast<int>(prims.size()); ++i)
    for (int j = i + 1; j < static_cast<int>(prims.size()); ++j) {
      const int la = prims[i].link, lb = prims[j].link;
      const bool apart = robot.joints_between(la, lb) >= 2;
      if ((apart || listed(allow, la, lb)) && !listed(deny, la, lb)) out.emplace_back(i, j);
    }
  return out;
}

}  // namespace

std::vector<RobotPair> select_pairs(const Robot& robot, const std::vector<Obstacle>& obstacles,
                                    const PairSelection& selection) {
  const auto& prims = robot.primitives();
  std::vector<RobotPair> pairs;
  if (selection.obstacles)
    for (int i = 0; i < static_cast<int>(prims.size()); ++i)
      for (int j = 0; j < static_cast<int>(obstacles.size()); ++j)
        pairs.push_back({i, j, false, prims[i].name + "/" + obstacles[j].name});
  if (selection.self)
    for (const auto& [i, j] : self_pairs(robot, selection))
      pairs.push_back({i, j, true, prims[i].name + "/" + prims[j].name});
  return pairs;
}

DistanceModel::DistanceModel(std::shared_ptr<const Robot> robot, std::vector<Obstacle> obstacles, Metric metric,
                             const GapParams& params, const PairSelection& selection, const BodyOptions& options,
                             const std::function<void()>& checkpoint)
    : robot_(std::move(robot)), obstacles_(std::move(obstacles)), metric_(metric), params_(params), pool_(std::make_shared<Pool>()) {
  if (metric_ == Metric::gap) check_params(params_);
  const auto body_options = [&](const Shape& shape, const P2SOptions& given, const GapParams& p) {
    return options ? options(shape, given) : gap_body_options(shape, given, p);
  };
  pairs_ = select_pairs(*robot_, obstacles_, selection);
  const auto& prims = robot_->primitives();
  if (metric_ == Metric::gap)
    for (std::size_t i = 0; i < prims.size(); ++i) {
      const LinkPrimitive& prim = prims[i];
      std::string note;
      const EuclideanShape& shape = robot_->euclidean_shape(static_cast<int>(i));
      const GapParams own = element_params(
          shape, params_, [&](const GapParams& p) { return body_options(prim.shape, {}, p); }, note, checkpoint);
      if (!note.empty()) warnings_.push_back("collision element \"" + prim.name + "\": " + note);
      if (checkpoint) checkpoint();
      robot_gap_.emplace_back(shape, Pose{}, own, body_options(prim.shape, {}, own), "robot." + prim.name);
    }
  for (std::size_t j = 0; j < obstacles_.size(); ++j) {
    const Obstacle& o = obstacles_[j];
    if (checkpoint) checkpoint();
    obstacle_euclid_.emplace_back(o.shape);
    if (metric_ == Metric::gap)
      obstacle_gap_.emplace_back(o.shape, o.pose, params_, body_options(o.shape, o.options, params_),
                                 "obstacles[" + std::to_string(j) + "]");
  }
}

struct DistanceModel::Pool {
  std::mutex mutex;
  std::vector<std::unique_ptr<Workspace>> free;
};

std::unique_ptr<DistanceModel::Workspace> DistanceModel::acquire() const {
  {
    std::lock_guard lock(pool_->mutex);
    if (!pool_->free.empty()) {
      std::unique_ptr<Workspace> w = std::move(pool_->free.back());
      pool_->free.pop_back();
      w->tracks.assign(pairs_.size(), GapTrack{});
      return w;
    }
  }
  return std::make_unique<Workspace>(workspace());
}

void DistanceModel::recycle(std::unique_ptr<Workspace> w) const {
  std::lock_guard lock(pool_->mutex);
  if (pool_->free.size() < 64) pool_->free.push_back(std::move(w));
}

DistanceModel::Workspace DistanceModel::workspace() const {
  Workspace w;
  w.robot_gap = robot_gap_;
  w.robot_pose.resize(robot_->primitives().size());
  w.robot_jac.resize(robot_->primitives().size());
  w.obstacle_gap = obstacle_gap_;
  for (const Obstacle& o : obstacles_) w.obstacle_pose.push_back(o.pose);
  w.tracks.assign(pairs_.size(), GapTrack{});
  return w;
}

void DistanceModel::place_obstacles(Workspace& w, std::span<const Pose> poses) const {
  if (!poses.empty() && poses.size() != obstacles_.size())
    throw InvalidInput("obstacles", "the model has " + std::to_string(obstacles_.size()) + " obstacles, not " +
                                        std::to_string(poses.size()));
  for (std::size_t j = 0; j < obstacles_.size(); ++j) {
    const Pose& given = poses.empty() ? obstacles_[j].pose : poses[j];
    Pose& pose = w.obstacle_pose[j];
    // A hull's world rows are recomputed only for an obstacle that moved.
    if (pose.position == given.position && pose.rotation.coeffs() == given.rotation.coeffs()) continue;
    pose = given;
    if (metric_ == Metric::gap) w.obstacle_gap[j].set_pose(given);
  }
}

void DistanceModel::evaluate(const VecQ& q, Workspace& w, bool tracking, std::span<PairDistance> out, GradQ& grad,
                             const Adjust& adjust) const {
  robot_->check_q(q);
  robot_->forward(q, w.kinematics);
  evaluate_at(w, tracking, out, grad, adjust);
}

void DistanceModel::evaluate_at(Workspace& w, bool tracking, std::span<PairDistance> out, GradQ& grad,
                                const Adjust& adjust) const {
  const Kinematics& k = w.kinematics;
  const auto& prims = robot_->primitives();
  for (std::size_t i = 0; i < prims.size(); ++i) {
    w.robot_pose[i] = robot_->primitive_pose(k, static_cast<int>(i));
    robot_->point_jacobian(k, prims[i].link, w.robot_pose[i].position, w.robot_jac[i]);
    if (metric_ == Metric::gap) w.robot_gap[i].set_pose(w.robot_pose[i]);
  }
  grad.resize(static_cast<Eigen::Index>(pairs_.size()), robot_->dof());
  for (std::size_t p = 0; p < pairs_.size(); ++p) {
    const RobotPair& pair = pairs_[p];
    PairDistance& s = out[p];
    s = PairDistance{};
    Vec6 ga, gb;
    if (metric_ == Metric::gap) {
      const GapBody& A = w.robot_gap[pair.a];
      const GapBody& B = pair.self ? w.robot_gap[pair.b] : w.obstacle_gap[pair.b];
      // Tracking: Newton from the witnesses predicted from the previous solution, stopping on its
      // error estimate; an empty track (first call, after an overlap or a failed warm solve) is
      // solved cold, as gap_distance does.
      GapTrack& track = w.tracks[p];
      if (!tracking) track = GapTrack{};
      s.cold = !track.valid;
      GapResult g = gap_distance_tracked(A, B, params_, track);
      if (!s.cold && !g.converged) {
        track = GapTrack{};
        g = gap_distance_tracked(A, B, params_, track);
        s.cold = true;
      }
      s.clearance = s.cold ? g.euclidean.distance : std::numeric_limits<double>::quiet_NaN();
      if (adjust) adjust(static_cast<int>(p), A, B, g, s);
      s.distance = g.distance;
      s.witness_a = g.witness_a;
      s.witness_b = g.witness_b;
      s.overlap = g.overlap;
      s.iterations = g.iterations;
      s.converged = g.converged;
      ga = g.gradient_a;
      gb = g.gradient_b;
    } else {
      const Pose& pb = pair.self ? w.robot_pose[pair.b] : w.obstacle_pose[pair.b];
      const EuclideanShape& eb = pair.self ? robot_->euclidean_shape(pair.b) : obstacle_euclid_[pair.b];
      const EuclideanResult e = euclidean_distance(robot_->euclidean_shape(pair.a), w.robot_pose[pair.a], eb, pb);
      s.distance = s.clearance = e.distance;
      s.witness_a = e.witness_a;
      s.witness_b = e.witness_b;
      s.overlap = e.distance <= 0;
      ga = e.gradient_a;
      gb = e.gradient_b;
    }
    // Chain rule: dD/dq = g_vᵀ J_v(o) + g_ωᵀ J_ω for the origin o of each moving shape.
    grad.row(static_cast<Eigen::Index>(p)) = ga.transpose() * w.robot_jac[pair.a];
    if (pair.self)
      grad.row(static_cast<Eigen::Index>(p)) += gb.transpose() * w.robot_jac[pair.b];
    else
      s.obstacle_gradient = gb;
  }
}

DistanceBatch distances(const DistanceModel& model, std::span<const double> q, int n, const BatchOptions& options) {
  const int dof = model.dof();
  const int np = static_cast<int>(model.pairs().size());
  if (n < 0 || q.size() != static_cast<std::size_t>(n) * static_cast<std::size_t>(dof))
    throw InvalidInput("q", "q must have shape (N, " + std::to_string(dof) + ")");
  if (!options.warm_start.empty() && options.warm_start.size() != static_cast<std::size_t>(np))
    throw InvalidInput("warm_start", "warm_start holds the tracks of another pair set (" +
                                         std::to_string(options.warm_start.size()) + " pairs, not " + std::to_string(np) + ")");
  // The field name is built only for a configuration that fails (not 10,000 strings per batch).
  for (int i = 0; i < n; ++i) {
    const Eigen::Map<const VecQ> qi(q.data() + static_cast<std::size_t>(i) * dof, dof);
    if (!(qi.array().abs() <= 1e6).all())  // false for NaN and ±inf too
      model.robot().check_q(qi, "q[" + std::to_string(i) + "]");
  }

  DistanceBatch b;
  b.n = n;
  b.pairs = np;
  b.dof = dof;
  const auto cells = static_cast<std::size_t>(n) * static_cast<std::size_t>(np);
  b.distance.resize(cells);
  b.jacobian.resize(cells * dof);
  b.witness_robot.resize(cells * 3);
  b.witness_obstacle.resize(cells * 3);
  b.obstacle_gradient.resize(cells * 6);
  b.overlap.resize(cells);
  b.converged.resize(cells);
  b.iterations.resize(cells);
  static const unsigned hw = std::max(1u, std::thread::hardware_concurrency());  // reads /sys: once
  const auto runs = static_cast<std::size_t>(
      std::max(1, std::min(n, static_cast<int>(options.threads == 0 ? hw : options.threads))));
  std::vector<GapTrack> last;
  parallel_for(runs, static_cast<unsigned>(runs), [&](std::size_t r) {
    const int begin = static_cast<int>(static_cast<std::size_t>(n) * r / runs);
    const int end = static_cast<int>(static_cast<std::size_t>(n) * (r + 1) / runs);
    std::unique_ptr<DistanceModel::Workspace> held = model.acquire();
    DistanceModel::Workspace& w = *held;
    if (r == 0 && !options.warm_start.empty()) w.tracks.assign(options.warm_start.begin(), options.warm_start.end());
    model.place_obstacles(w, options.obstacle_poses);  // a pooled workspace's may be its last user's
    std::vector<PairDistance> out(static_cast<std::size_t>(np));
    GradQ grad(np, dof);
    for (int i = begin; i < end; ++i) {
      if (options.cancel != nullptr && options.cancel->load(std::memory_order_relaxed)) throw Cancelled();
      model.robot().forward(Eigen::Map<const VecQ>(q.data() + static_cast<std::size_t>(i) * dof, dof), w.kinematics);
      model.evaluate_at(w, options.tracking, out, grad);
      for (int p = 0; p < np; ++p) {
        const std::size_t c = static_cast<std::size_t>(i) * np + p;
        const PairDistance& s = out[p];
        b.distance[c] = s.distance;
        for (int d = 0; d < 3; ++d) {
          b.witness_robot[c * 3 + d] = s.witness_a[d];
          b.witness_obstacle[c * 3 + d] = s.witness_b[d];
        }
        for (int j = 0; j < dof; ++j) b.jacobian[c * dof + j] = grad(p, j);
        for (int k = 0; k < 6; ++k) b.obstacle_gradient[c * 6 + k] = s.obstacle_gradient[k];
        b.overlap[c] = s.overlap;
        b.converged[c] = s.converged;
        b.iterations[c] = s.iterations;
      }
    }
    if (r + 1 == runs) last = w.tracks;
    model.recycle(std::move(held));
  });
  b.tracks = std::move(last);
  return b;
}

}  // namespace distlab::robot
