// distlab-bench-fields: the cost of a Kelvin field's CBF row (h and ∇_q h at one control point:
// FK is shared, then the query and the chain rule) beside the rows a user would otherwise build:
// the Euclidean distance to the object's mesh (CGAL AABB tree, closest point), and the pair rows
// of the same robot (GAP tracked and Euclidean FCL), all on the configurations of one rollout.
// usage: distlab-bench-fields [--scenario NAME] [--repeat N] [--json FILE]
// NAME: a scenario with fields (default wrench_grasp). Times are medians over N repeats (wall
// clock); the load average (/proc/loadavg) is printed before and after: compare ratios within
// one run, absolute times only at load < 1.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "../src/huge_page_heap.hpp"
#include "distlab/cbf/rollout.hpp"
#include "distlab/server/cbf_json.hpp"
#include "load_average.hpp"

namespace {

using namespace distlab;
using nlohmann::json;
using Clock = std::chrono::steady_clock;

double median(std::vector<double> v) {
  std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

// Microseconds of fn() per unit, median over `repeat` runs.
template <class Fn>
double per_unit(int repeat, double units, Fn&& fn) {
  std::vector<double> t;
  for (int r = 0; r < repeat; ++r) {
    const auto t0 = Clock::now();
    fn();
    t.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count() / units);
  }
  return median(t);
}

}  // namespace

int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  distlab::app::use_huge_page_heap(argv);
  std::string scenario = "wrench_grasp", json_file;
  int repeat = 5;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--scenario" && i + 1 < argc) scenario = argv[++i];
    else if (a == "--repeat" && i + 1 < argc) repeat = std::max(1, std::atoi(argv[++i]));
    else if (a == "--json" && i + 1 < argc) json_file = argv[++i];
    else {
      std::cerr << "usage: distlab-bench-fields [--scenario NAME] [--repeat N] [--json FILE]\n";
      return 2;
    }
  }
  const std::string load_before = bench::load_average();
  const server::CbfRequest req = server::parse_cbf_request({{"scenario", scenario}, {"metric", "euclidean"}});
  const cbf::Scenario& sc = req.scenario;
  if (sc.fields.empty()) {
    std::cerr << "scenario " << scenario << " has no fields\n";
    return 2;
  }
  cbf::RolloutOptions options;
  options.record_pairs = false;
  const cbf::RolloutRecord rec = cbf::rollout(sc, cbf::Metric::euclidean, options);
  std::vector<robot::Kinematics> ks;
  for (const cbf::StepRecord& s : rec.steps) ks.push_back(sc.robot->forward(s.q));
  const robot::Robot& robot = *sc.robot;
  const auto steps = static_cast<double>(ks.size());

  cbf::FieldBarrier barrier(sc.fields, sc.control_points);
  const double rows = barrier.rows();
  std::vector<cbf::FieldPointSample> samples;
  Eigen::MatrixXd grad;
  const double field_tracked = per_unit(repeat, steps * rows, [&] {
    barrier.reset_hints();
    for (const auto& k : ks) barrier.evaluate(robot, k, samples, grad);
  });
  const double field_cold = per_unit(repeat, steps * rows, [&] {
    for (const auto& k : ks) {
      barrier.reset_hints();
      barrier.evaluate(robot, k, samples, grad);
    }
  });
  // The baseline: Euclidean distance to the same object's mesh per point (closest point by CGAL's
  // AABB tree; its direction would be the gradient), and the same point Jacobian.
  const kelvin::SurfaceOracle oracle(sc.fields.front().field->surface());
  const Pose& pose = sc.fields.front().pose;
  robot::Jac J;
  double sink = 0;
  const double points = static_cast<double>(sc.control_points.size());
  const double aabb = per_unit(repeat, steps * points, [&] {
    for (const auto& k : ks)
      for (int p = 0; p < static_cast<int>(points); ++p) {
        const Vec3 x = barrier.world_point(k, p);
        int face = 0;
        Vec3 w;
        oracle.closest(pose.to_local(x), face, w);
        robot.point_jacobian(k, sc.control_points[static_cast<std::size_t>(p)].link, x, J);
        sink += w[0] + J(0, 0);
      }
  });
  // The pair rows of the same robot and obstacles (ms per step / pairs).
  std::vector<std::pair<std::string, double>> pair_rows;
  double pairs = 0;
  for (const robot::Metric m : {robot::Metric::gap, robot::Metric::euclidean}) {
    robot::PairSelection sel;
    sel.self = sc.self_collision;
    const robot::DistanceModel model(sc.robot, sc.obstacles, m, sc.gap, sel);
    auto w = model.workspace();
    std::vector<robot::PairDistance> out(model.pairs().size());
    robot::GradQ g;
    pairs = static_cast<double>(model.pairs().size());
    pair_rows.emplace_back(m == robot::Metric::gap ? "GAP pair (tracked)" : "Euclidean pair (FCL)",
                           per_unit(repeat, steps * pairs, [&] {
                             w.tracks.assign(model.pairs().size(), {});
                             for (const auto& k : ks) {
                               w.kinematics = k;
                               model.evaluate_at(w, true, out, g);
                             }
                           }));
  }
  const std::string load_after = bench::load_average();

  std::printf(
      "distlab-bench-fields: scenario %s, %zu steps of its rollout, %d control points × %zu fields, %.0f pairs, "
      "median of %d\nload average before: %s   after: %s\n\n",
      scenario.c_str(), ks.size(), static_cast<int>(points), sc.fields.size(), pairs, repeat, load_before.c_str(),
      load_after.c_str());
  std::printf("| row | µs per row | × field row |\n|---|---|---|\n");
  const std::vector<std::pair<std::string, double>> table = {
      {"Kelvin field row (h, smoothed ∇h, J_x; tracked cell)", field_tracked},
      {"Kelvin field row, no hint (seeding grid)", field_cold},
      {"mesh distance row (CGAL AABB closest point, J_x)", aabb},
      pair_rows[0],
      pair_rows[1]};
  for (const auto& [name, us] : table) std::printf("| %s | %.3f | %.2f |\n", name.c_str(), us, us / field_tracked);
  if (!json_file.empty()) {
    json out = {{"scenario", scenario}, {"steps", ks.size()}, {"control_points", points}, {"pairs", pairs}, {"repeat", repeat}, {"load_before", load_before}, {"load_after", load_after}, {"sink", sink}};
    for (const auto& [name, us] : table) out["us_per_row"][name] = us;
    std::ofstream(json_file) << out.dump(2) << "\n";
  }
  return 0;
}
