// The batched call distances(): the pair table and its selection, one thread against two (the
// second run starts cold where the first one tracks), tracking off against gap_distance of each
// pair built here, the warm start carried from one call to the next, and bad input naming the
// field.
#include <algorithm>
#include <atomic>
#include <cmath>
#include <numbers>
#include <random>
#include <set>

#include <gtest/gtest.h>

#include "robot_test_util.hpp"

#include "distlab/gap/validator.hpp"
#include "distlab/geometry/progress.hpp"
#include "distlab/robot/distances.hpp"

namespace distlab::robot {
namespace {

// gap_distance_tracked ends when the witnesses are within the solver's tol of the solution
// (GapParams::tol, 1e-10 m); a cold solve converges to tol too. D is stationary in the witnesses
// (a saddle value): its error is second order in theirs.
constexpr double kWitnessTol = 2 * 1e-10;

std::vector<Obstacle> corridor() {
  return {{"wall1", Box{Vec3(0.35, 0.05, 0.90)}, {Vec3(0.53, 0.16, 0.45), Quat::Identity()}},
          {"wall2", Box{Vec3(0.35, 0.05, 0.90)}, {Vec3(0.53, -0.16, 0.45), Quat::Identity()}},
          {"roof", Box{Vec3(0.35, 0.35, 0.05)}, {Vec3(0.53, 0, 0.925), Quat::Identity()}}};
}

PairSelection with_self() {
  PairSelection s;
  s.self = true;
  return s;
}

// n configurations along a smooth path through the limits' middle: q_i(t) = mid_i +
// 0.4 · half range_i · sin(2π f_i t + φ_i), t in [0, 1] (steps of ~0.01 rad at n = 200).
std::vector<double> trajectory(const Robot& robot, int n) {
  std::vector<double> q;
  for (int s = 0; s < n; ++s) {
    const double t = static_cast<double>(s) / n;
    for (int i = 0; i < robot.dof(); ++i) {
      const double mid = 0.5 * (robot.q_min()[i] + robot.q_max()[i]), half = 0.5 * (robot.q_max()[i] - robot.q_min()[i]);
      q.push_back(mid + 0.4 * half * std::sin(2 * std::numbers::pi * (0.5 + 0.25 * i) * t + 0.7 * i));
    }
  }
  return q;
}

BatchOptions options(unsigned threads, bool tracking) {
  BatchOptions o;
  o.threads = threads;
  o.tracking = tracking;
  return o;
}

std::string error_of(const std::function<void()>& f) { return test::field_of(f); }

TEST(RobotPairs, TableAndSelectionByLinkNames) {
  const auto panda = test::panda();
  const auto& prims = panda->primitives();
  const DistanceModel obstacles_only(panda, corridor(), Metric::gap, GapParams{}, PairSelection{});
  ASSERT_EQ(obstacles_only.pairs().size(), 27u);
  for (int p = 0; p < 27; ++p) {  // element-major
    const RobotPair& pair = obstacles_only.pairs()[p];
    EXPECT_EQ(pair.a, p / 3);
    EXPECT_EQ(pair.b, p % 3);
    EXPECT_FALSE(pair.self);
    EXPECT_EQ(pair.name, prims[p / 3].name + "/" + corridor()[p % 3].name);
  }
  // The DH frame of each element (franka-corridor.md: links 1 2 3 4 5 5 6 7 7); self pairs are
  // frames two or more apart.
  const int frame[9] = {1, 2, 3, 4, 5, 5, 6, 7, 7};
  const auto self_set = [&](const PairSelection& s) {
    std::set<std::pair<int, int>> out;
    const DistanceModel model(panda, {}, Metric::euclidean, GapParams{}, s);
    for (const RobotPair& pair : model.pairs()) {
      EXPECT_TRUE(pair.self);
      EXPECT_LT(pair.a, pair.b);
      EXPECT_EQ(pair.name, prims[pair.a].name + "/" + prims[pair.b].name);
      out.emplace(pair.a, pair.b);
    }
    EXPECT_EQ(out.size(), model.pairs().size());
    return out;
  };
  std::set<std::pair<int, int>> expected;
  for (int i = 0; i < 9; ++i)
    for (int j = i + 1; j < 9; ++j)
      if (frame[j] - frame[i] >= 2) expected.emplace(i, j);
  ASSERT_EQ(expected.size(), 25u);
  PairSelection s = with_self();
  s.obstacles = false;
  EXPECT_EQ(self_set(s), expected);
  // Allowed: links 1 and 2 (one joint apart) and link 5 with itself (its box and cylinder);
  // denied: links 7 and 1 (either order), and link 1–2 again (deny wins).
  s.allow = {{"panda_link1", "panda_link2"}, {"panda_link5", "panda_link5"}, {"panda_link3", "panda_link4"}};
  s.deny = {{"panda_link7", "panda_link1"}, {"panda_link3", "panda_link4"}};
  expected.emplace(0, 1);
  expected.emplace(4, 5);
  expected.erase({0, 7});
  expected.erase({0, 8});
  EXPECT_EQ(self_set(s), expected);
  // Both kinds: the obstacle pairs first.
  s.obstacles = true;
  const DistanceModel all(panda, corridor(), Metric::gap, GapParams{}, s);
  ASSERT_EQ(all.pairs().size(), 27 + expected.size());
  EXPECT_FALSE(all.pairs()[26].self);
  EXPECT_TRUE(all.pairs()[27].self);

  // Unknown links name their list entry.
  s.deny = {{"panda_link7", "panda_hand"}};
  std::string e = error_of([&] { DistanceModel(panda, {}, Metric::gap, GapParams{}, s); });
  EXPECT_EQ(e.rfind("pairs.deny[0]: ", 0), 0u) << e;
  EXPECT_NE(e.find("\"panda_hand\""), std::string::npos) << e;
  s.deny.clear();
  s.allow = {{"panda_link1", "panda_link2"}, {"nowhere", "panda_link2"}};
  e = error_of([&] { DistanceModel(panda, {}, Metric::gap, GapParams{}, s); });
  EXPECT_EQ(e.rfind("pairs.allow[1]: ", 0), 0u) << e;
  GapParams bad;
  bad.h = -1;
  e = error_of([&] { DistanceModel(panda, corridor(), Metric::gap, bad, PairSelection{}); });
  EXPECT_EQ(e.rfind("params.h: ", 0), 0u) << e;
}

// The first run of two threads is the single thread's first half, call for call: equal. The
// second run starts cold at the middle where the single thread continues its tracks: equal within
// the solver's tolerance.
TEST(RobotBatch, OneAndTwoThreadsAgree) {
  const auto panda = test::panda();
  const int n = 200;
  const std::vector<double> q = trajectory(*panda, n);
  for (const Metric metric : {Metric::gap, Metric::euclidean}) {
    const DistanceModel model(panda, corridor(), metric, GapParams{}, with_self());
    const DistanceBatch one = distances(model, q, n, options(1, true)), two = distances(model, q, n, options(2, true));
    ASSERT_EQ(one.n, n);
    ASSERT_EQ(one.pairs, 52);
    ASSERT_EQ(one.dof, 7);
    ASSERT_EQ(one.jacobian.size(), static_cast<std::size_t>(n) * 52 * 7);
    ASSERT_EQ(two.distance.size(), one.distance.size());
    int overlaps = 0;
    double worst_d = 0, worst_w = 0, worst_g = 0;
    for (int c = 0; c < n; ++c)
      for (int p = 0; p < 52; ++p) {
        const std::size_t cell = static_cast<std::size_t>(c) * 52 + p;
        ASSERT_EQ(one.overlap[cell], two.overlap[cell]) << c << " " << model.pairs()[p].name;
        EXPECT_TRUE(one.converged[cell]);
        overlaps += one.overlap[cell];
        if (c < n / 2) {
          ASSERT_EQ(one.distance[cell], two.distance[cell]) << c;
          for (int k = 0; k < 3; ++k) ASSERT_EQ(one.witness_robot[cell * 3 + k], two.witness_robot[cell * 3 + k]) << c;
          for (int k = 0; k < 7; ++k) ASSERT_EQ(one.jacobian[cell * 7 + k], two.jacobian[cell * 7 + k]) << c;
          continue;
        }
        if (one.overlap[cell]) continue;
        const Eigen::Map<const Eigen::VectorXd> g1(&one.jacobian[cell * 7], 7), g2(&two.jacobian[cell * 7], 7);
        const Vec3 wa1(&one.witness_robot[cell * 3]), wa2(&two.witness_robot[cell * 3]);
        const Vec3 wb1(&one.witness_obstacle[cell * 3]), wb2(&two.witness_obstacle[cell * 3]);
        worst_d = std::max(worst_d, std::abs(one.distance[cell] - two.distance[cell]) / one.distance[cell]);
        worst_w = std::max({worst_w, (wa1 - wa2).norm(), (wb1 - wb2).norm()});
        // Relative to the larger entry, or to 1e-6 m/rad where every entry is rounding (a pair the
        // path moves rigidly, e.g. link5_cylinder/link7_box here: entries ~1e-18 in both runs).
        worst_g = std::max(worst_g, (g1 - g2).cwiseAbs().maxCoeff() / std::max(g1.cwiseAbs().maxCoeff(), 1e-6));
      }
    EXPECT_LT(overlaps, n * 52 / 10) << "the path should keep most pairs apart";
    if (metric == Metric::euclidean) {  // nothing tracked: the same calls
      EXPECT_EQ(worst_d, 0);
      EXPECT_EQ(worst_w, 0);
      EXPECT_EQ(worst_g, 0);
    } else {
      // Witnesses within both solves' tol; D (relative) to rounding, its error being second order;
      // the gradient, first order in the witnesses, to tol over the pairs' smallest distance
      // (~1 cm on this path): 1e-8 relative.
      EXPECT_LE(worst_w, kWitnessTol);
      EXPECT_LE(worst_d, 1e-12);
      EXPECT_LE(worst_g, 1e-8);
    }
    char worst[96];
    std::snprintf(worst, sizeof worst, "D %.3g, witnesses %.3g m, gradient %.3g", worst_d, worst_w, worst_g);
    RecordProperty(std::string(to_string(metric)) + "_worst", worst);
  }
}

// Tracking off: every pair at every configuration is gap_distance of the two bodies built here at
// the FK poses (with the model's documented options), and its row the chain rule through the
// point Jacobians of the elements' origins.
TEST(RobotBatch, UntrackedEqualsColdGapDistancePerConfiguration) {
  const auto panda = test::panda();
  const int n = 20;
  const std::vector<double> q = trajectory(*panda, n);
  const GapParams params;
  const std::vector<Obstacle> obstacles = corridor();
  const DistanceModel model(panda, obstacles, Metric::gap, params, with_self());
  const DistanceBatch b = distances(model, q, n, options(2, false));
  const auto body = [&](const Shape& shape, const Pose& pose, const P2SOptions& o = {}) {
    return GapBody(shape, pose, params, gap_body_options(shape, o, params));
  };
  int compared = 0;
  for (int c = 0; c < n; ++c) {
    const Kinematics k = panda->forward(Eigen::Map<const VecQ>(&q[static_cast<std::size_t>(c) * 7], 7));
    for (int p = 0; p < b.pairs; ++p) {
      const RobotPair& pair = model.pairs()[p];
      const auto& prims = panda->primitives();
      const Pose pa = panda->primitive_pose(k, pair.a);
      const Pose pb = pair.self ? panda->primitive_pose(k, pair.b) : obstacles[pair.b].pose;
      const GapBody A = body(prims[pair.a].shape, pa);
      const GapBody B = pair.self ? body(prims[pair.b].shape, pb) : body(obstacles[pair.b].shape, pb, obstacles[pair.b].options);
      const GapResult r = gap_distance(A, B, params);
      const std::size_t cell = static_cast<std::size_t>(c) * b.pairs + p;
      ASSERT_EQ(static_cast<bool>(b.overlap[cell]), r.overlap) << c << " " << pair.name;
      EXPECT_EQ(b.distance[cell], r.distance) << c << " " << pair.name;
      EXPECT_EQ(Vec3(&b.witness_robot[cell * 3]), r.witness_a) << c << " " << pair.name;
      EXPECT_EQ(Vec3(&b.witness_obstacle[cell * 3]), r.witness_b) << c << " " << pair.name;
      EXPECT_EQ(b.iterations[cell], r.iterations);
      Eigen::RowVectorXd row = r.gradient_a.transpose() * panda->point_jacobian(k, prims[pair.a].link, pa.position);
      if (pair.self) row += r.gradient_b.transpose() * panda->point_jacobian(k, prims[pair.b].link, pb.position);
      const Eigen::Map<const Eigen::RowVectorXd> got(&b.jacobian[cell * 7], 7);
      EXPECT_LE((got - row).cwiseAbs().maxCoeff(), 1e-15 * (1 + row.cwiseAbs().maxCoeff())) << c << " " << pair.name;
      compared += !r.overlap;
    }
  }
  EXPECT_GT(compared, n * b.pairs * 9 / 10);
}

// Two calls, the second warm-started from the first's tracks, are the one call over both parts.
TEST(RobotBatch, WarmStartContinuesTheTracks) {
  const auto panda = test::panda();
  const int n = 60, first = 25;
  const std::vector<double> q = trajectory(*panda, n);
  const DistanceModel model(panda, corridor(), Metric::gap, GapParams{}, with_self());
  const DistanceBatch whole = distances(model, q, n, options(1, true));
  const DistanceBatch head = distances(model, std::span(q).first(static_cast<std::size_t>(first) * 7), first, options(1, true));
  ASSERT_EQ(head.tracks.size(), model.pairs().size());
  BatchOptions warm = options(1, true);
  warm.warm_start = head.tracks;
  const auto rest = std::span(q).subspan(static_cast<std::size_t>(first) * 7);
  const DistanceBatch tail = distances(model, rest, n - first, warm);
  const std::size_t offset = static_cast<std::size_t>(first) * whole.pairs;
  for (std::size_t cell = 0; cell < tail.distance.size(); ++cell) {
    ASSERT_EQ(tail.distance[cell], whole.distance[offset + cell]) << cell;
    ASSERT_EQ(tail.iterations[cell], whole.iterations[offset + cell]) << cell;
    for (int k = 0; k < 7; ++k) ASSERT_EQ(tail.jacobian[cell * 7 + k], whole.jacobian[(offset + cell) * 7 + k]) << cell;
  }
  for (std::size_t cell = 0; cell < head.distance.size(); ++cell) ASSERT_EQ(head.distance[cell], whole.distance[cell]);
  // Warm, the first configuration of the tail took fewer Newton steps than cold.
  const DistanceBatch cold_tail = distances(model, rest, n - first, options(1, true));
  int warm_steps = 0, cold_steps = 0;
  for (int p = 0; p < tail.pairs; ++p) warm_steps += tail.iterations[p], cold_steps += cold_tail.iterations[p];
  EXPECT_LT(warm_steps, cold_steps);

  // Tracks of another pair set.
  const DistanceModel obstacles_only(panda, corridor(), Metric::gap, GapParams{}, PairSelection{});
  const std::string e = error_of([&] { distances(obstacles_only, rest, n - first, warm); });
  EXPECT_EQ(e.rfind("warm_start: ", 0), 0u) << e;
}

// Obstacles moved between calls (BatchOptions::obstacle_poses) without a new model: each call
// gives what a model built at those poses gives (GAP tracked from the last call's tracks, within
// the solvers' tolerances of a cold solve; Euclidean bit for bit), and the poses matter (the
// unmoved model's distances differ). A later call without poses gets the model's own back
// (the pooled workspace's), bit for bit; a wrong count of poses names "obstacles".
TEST(RobotBatch, MovedObstaclesNeedNoNewModel) {
  const auto panda = test::panda();
  const int n = 4, calls = 5;
  const std::vector<double> q = trajectory(*panda, n * calls);
  for (const Metric metric : {Metric::gap, Metric::euclidean}) {
    const DistanceModel model(panda, corridor(), metric, GapParams{}, with_self());
    const int np = static_cast<int>(model.pairs().size());
    const DistanceBatch unmoved = distances(model, q, n * calls, options(1, true));
    std::vector<GapTrack> tracks;
    double worst_d = 0, worst_w = 0, worst_g = 0;
    int unchanged = 0, separate = 0;  // obstacle pairs apart whose distance did not move, of all apart
    for (int k = 0; k < calls; ++k) {
      // Each obstacle 1 to 5 mm and 0.5° to 2.5° further along a motion of its own.
      std::vector<Obstacle> moved = corridor();
      std::vector<Pose> poses;
      for (std::size_t j = 0; j < moved.size(); ++j) {
        Pose& pose = moved[j].pose;
        const double s = (k + 1) * 1e-3, angle = (k + 1) * 0.5 * std::numbers::pi / 180;
        pose.position += s * Vec3(1.0 - static_cast<double>(j), 0.5, 0.3 * static_cast<double>(j));
        pose.rotation = Quat(Eigen::AngleAxisd(angle, Vec3(0.2, 1.0, 0.1 * static_cast<double>(j)).normalized()));
        poses.push_back(pose);
      }
      const auto qk = std::span(q).subspan(static_cast<std::size_t>(k) * n * 7, static_cast<std::size_t>(n) * 7);
      BatchOptions o = options(1, true);
      o.obstacle_poses = poses;
      o.warm_start = tracks;
      const DistanceBatch got = distances(model, qk, n, o);
      tracks = got.tracks;
      const DistanceModel built(panda, moved, metric, GapParams{}, with_self());
      const DistanceBatch want = distances(built, qk, n, options(1, false));
      for (std::size_t cell = 0; cell < got.distance.size(); ++cell) {
        const std::size_t at_unmoved = static_cast<std::size_t>(k) * n * np + cell;
        ASSERT_EQ(got.overlap[cell], want.overlap[cell]) << k << " " << cell;
        const bool obstacle_pair = !model.pairs()[cell % static_cast<std::size_t>(np)].self;
        if (obstacle_pair && !got.overlap[cell] && got.distance[cell] == unmoved.distance[at_unmoved]) ++unchanged;
        separate += obstacle_pair && !got.overlap[cell];
        if (metric == Metric::euclidean) {
          ASSERT_EQ(got.distance[cell], want.distance[cell]) << k << " " << cell;
          for (int c = 0; c < 7; ++c) ASSERT_EQ(got.jacobian[cell * 7 + c], want.jacobian[cell * 7 + c]);
          continue;
        }
        ASSERT_TRUE(got.converged[cell]);
        if (got.overlap[cell]) continue;
        const Eigen::Map<const Eigen::VectorXd> g1(&got.jacobian[cell * 7], 7), g2(&want.jacobian[cell * 7], 7);
        worst_d = std::max(worst_d, std::abs(got.distance[cell] - want.distance[cell]) / want.distance[cell]);
        worst_w = std::max({worst_w, (Vec3(&got.witness_robot[cell * 3]) - Vec3(&want.witness_robot[cell * 3])).norm(),
                            (Vec3(&got.witness_obstacle[cell * 3]) - Vec3(&want.witness_obstacle[cell * 3])).norm()});
        worst_g = std::max(worst_g, (g1 - g2).cwiseAbs().maxCoeff() / std::max(g2.cwiseAbs().maxCoeff(), 1e-6));
      }
    }
    // Every obstacle pair apart moved with its obstacle.
    EXPECT_EQ(unchanged, 0) << to_string(metric);
    EXPECT_GT(separate, calls * n * 3 * 5) << to_string(metric);
    // As OneAndTwoThreadsAgree: witnesses within both solves' tol, D to rounding, the gradient 1e-8.
    EXPECT_LE(worst_w, kWitnessTol);
    EXPECT_LE(worst_d, 1e-12);
    EXPECT_LE(worst_g, 1e-8);
    // The pooled workspace is back at the model's poses.
    const DistanceBatch again = distances(model, q, n * calls, options(1, true));
    for (std::size_t cell = 0; cell < again.distance.size(); ++cell) ASSERT_EQ(again.distance[cell], unmoved.distance[cell]);
    BatchOptions one_pose = options(1, true);
    const std::vector<Pose> poses(1);
    one_pose.obstacle_poses = poses;
    const std::string e = error_of([&] { distances(model, std::span(q).first(static_cast<std::size_t>(n) * 7), n, one_pose); });
    EXPECT_EQ(e.rfind("obstacles: ", 0), 0u) << e;
  }
}

// The obstacles' pose gradients (obstacle_gradient: dD/d(v, ω), world frame, ω about the
// obstacle's origin) against differences of D, each obstacle moved by ±τ along each world axis
// and turned by ±τ about it (obstacle_poses; cold solves), at pairs at least 5 mm apart; zero for
// self pairs. A turned capsule besides the corridor's boxes.
// GAP: central differences, every coordinate. Euclidean: central differences along the moves (the
// distance between separated convex sets is differentiable in translation); a turn is not
// differentiable where the nearest features are parallel (the Panda's link cylinders beside the
// walls: the witness jumps from one end of a segment to the other, the paper's case against the
// Euclidean distance), and D = min over the witness pairs, so the gradient of FCL's pair lies
// between the one-sided quotients: (D(τ) − D(0))/τ ≤ g ≤ (D(0) − D(−τ))/τ.
TEST(RobotBatch, ObstacleGradientsMatchDifferences) {
  const auto panda = test::panda();
  const int n = 6;
  const std::vector<double> q = trajectory(*panda, n);
  std::vector<Obstacle> obstacles = corridor();
  obstacles.push_back({"rod", Capsule{0.03, 0.3}, {Vec3(0.45, 0.0, 0.2), Quat(Eigen::AngleAxisd(0.7, Vec3(1, 1, 0).normalized()))}});
  constexpr double kStep = 1e-6;
  for (const Metric metric : {Metric::gap, Metric::euclidean}) {
    SCOPED_TRACE(to_string(metric));
    const DistanceModel model(panda, obstacles, metric, GapParams{}, with_self());
    const auto np = static_cast<std::size_t>(model.pairs().size());
    const DistanceBatch base = distances(model, q, n, options(1, false));
    std::vector<Pose> poses;
    for (const Obstacle& o : obstacles) poses.push_back(o.pose);
    const auto moved = [&](std::size_t j, int k, double t) {
      std::vector<Pose> p = poses;
      if (k < 3)
        p[j].position[k] += t;
      else
        p[j].rotation = Quat(Eigen::AngleAxisd(t, Vec3::Unit(k - 3))) * p[j].rotation;
      BatchOptions o = options(1, false);
      o.obstacle_poses = p;
      return distances(model, q, n, o);
    };
    double worst = 0, worst_bracket = 0;
    int checked = 0, bracketed = 0;
    for (std::size_t j = 0; j < obstacles.size(); ++j)
      for (int k = 0; k < 6; ++k) {
        const DistanceBatch plus = moved(j, k, kStep), minus = moved(j, k, -kStep);
        for (std::size_t c = 0; c < base.distance.size(); ++c) {
          const RobotPair& pair = model.pairs()[c % np];
          const Eigen::Map<const Vec6> g(&base.obstacle_gradient[c * 6]);
          if (pair.self) {
            ASSERT_EQ(g.cwiseAbs().maxCoeff(), 0.0) << pair.name;
            continue;
          }
          if (static_cast<std::size_t>(pair.b) != j || base.distance[c] < 5e-3 || plus.overlap[c] || minus.overlap[c]) continue;
          const double scale = std::max(g.cwiseAbs().maxCoeff(), 1e-3);
          if (metric == Metric::euclidean && k >= 3) {
            const double right = (plus.distance[c] - base.distance[c]) / kStep, left = (base.distance[c] - minus.distance[c]) / kStep;
            worst_bracket = std::max({worst_bracket, (right - g[k]) / scale, (g[k] - left) / scale});
            ++bracketed;
            continue;
          }
          const double fd = (plus.distance[c] - minus.distance[c]) / (2 * kStep);
          worst = std::max(worst, std::abs(fd - g[k]) / scale);
          ++checked;
        }
      }
    // Most of the 6 (GAP) or 3 (Euclidean) coordinates of the 36 obstacle pairs, per configuration.
    EXPECT_GT(checked, n * (metric == Metric::gap ? 6 : 3) * 20);
    EXPECT_LE(worst, 1e-6);
    if (metric == Metric::euclidean) {
      EXPECT_GT(bracketed, n * 3 * 20);
      EXPECT_LE(worst_bracket, 1e-5);  // the one-sided quotients' own truncation, O(τ)
    }
    char text[96];
    std::snprintf(text, sizeof text, "%.3g over %d; bracket %.3g over %d", worst, checked, worst_bracket, bracketed);
    RecordProperty(std::string(to_string(metric)) + "_worst", text);
  }
}

// A box's orthogonal-face weight 1/(1 + margin) where it keeps Property 2, the gap library's
// general rule where it does not (a thin wall, a large floor: the validator finds an eigenvalue
// >= 1 with the face weight, none with the general rule). A millimetre box breaks it under both
// with h = 0.1 (a limit of the parameters, not of the weights): validation refuses it.
TEST(RobotBatch, BoxWeightsKeepProperty2) {
  const GapParams params;
  const double face = 1.0 / (1.0 + params.weight_margin);
  const auto weights_of = [&](const Vec3& size) { return gap_body_options(Box{size}, {}, params).weights; };
  const auto corridor = weights_of(Vec3(0.3, 0.1, 0.9));
  ASSERT_TRUE(corridor.has_value());
  EXPECT_DOUBLE_EQ((*corridor)[0], face);
  for (const Vec3& size : {Vec3(0.1, 1, 1), Vec3(4, 4, 0.05)}) {
    SCOPED_TRACE(::testing::Message() << size.transpose());
    P2SOptions face_weights;
    face_weights.weights = VecX::Constant(6, face);
    const GapBody with_face(Box{size}, Pose{}, params, face_weights, "box");
    EXPECT_FALSE(validate_p2s(with_face.p2s()).ok);  // the premise: the face weight breaks it here
    EXPECT_FALSE(weights_of(size).has_value());      // so the general rule is kept
    const GapBody chosen(Box{size}, Pose{}, params, gap_body_options(Box{size}, {}, params), "box");
    EXPECT_TRUE(validate_p2s(chosen.p2s()).ok);
  }
  // Given weights are the caller's.
  P2SOptions given;
  given.weights = VecX::Constant(6, 0.2);
  EXPECT_DOUBLE_EQ((*gap_body_options(Box{Vec3(0.1, 1, 1)}, given, params).weights)[0], 0.2);
}

TEST(RobotBatch, BadConfigurationsNameTheirIndex) {
  const auto panda = test::panda();
  const DistanceModel model(panda, corridor(), Metric::gap, GapParams{}, PairSelection{});
  std::vector<double> q = trajectory(*panda, 5);
  for (const double bad : {std::numeric_limits<double>::quiet_NaN(), std::numeric_limits<double>::infinity(), 2e6}) {
    std::vector<double> x = q;
    x[3 * 7 + 2] = bad;
    const std::string e = error_of([&] { distances(model, x, 5); });
    EXPECT_EQ(e.rfind("q[3][2]: ", 0), 0u) << e;
    EXPECT_NE(e.find("q[3][2]"), std::string::npos) << e;
  }
  EXPECT_EQ(error_of([&] { distances(model, std::span(q).first(34), 5); }).rfind("q: ", 0), 0u);  // not 5 × 7
  EXPECT_EQ(error_of([&] { distances(model, q, 4); }).rfind("q: ", 0), 0u);
  EXPECT_EQ(error_of([&] { distances(model, q, -1); }).rfind("q: ", 0), 0u);
  // None at all, more threads than configurations, a cancelled call.
  EXPECT_EQ(distances(model, std::span<const double>(), 0).distance.size(), 0u);
  EXPECT_EQ(distances(model, q, 5, options(16, false)).distance, distances(model, q, 5, options(1, false)).distance);
  std::atomic<bool> cancel{true};
  BatchOptions o;
  o.cancel = &cancel;
  EXPECT_THROW(distances(model, q, 5, o), Cancelled);
}

}  // namespace
}  // namespace distlab::robot
