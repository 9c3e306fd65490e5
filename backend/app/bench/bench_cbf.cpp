// distlab-bench-cbf: the corridor experiment (paper Section IV-B) with both metrics in one run:
// goal reached?, true clearance, smoothness of u per joint (paper Fig. 4), per-step times.
// usage: distlab-bench-cbf [--scenario FILE] [--duration S] [--no-audit] [--json FILE]
#include <cstdio>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "distlab/cbf/rollout.hpp"
#include "distlab/server/cbf_json.hpp"

namespace {

using namespace distlab::cbf;
using nlohmann::json;

json smooth_json(const RolloutRecord& r, double t0, double t1) {
  json tv = json::array(), rate = json::array();
  for (int j = 0; j < kDof; ++j) {
    const Smoothness s = smoothness(r, j, t0, t1);
    tv.push_back(s.total_variation);
    rate.push_back(s.max_rate);
  }
  return {{"total_variation", tv}, {"max_rate", rate}};
}

void print_smoothness(const RolloutRecord& g, const RolloutRecord& e, double t0, double t1) {
  std::printf("\nSmoothness of u, t in [%.1f, %.1f] s (paper Fig. 4: GAP smooth, Euclidean chatters)\n",
              t0, std::min(t1, g.steps.size() * g.dt));
  std::printf("  joint | TV(u) GAP  TV(u) Eucl  ratio E/G | max|du|/dt GAP  Eucl   ratio E/G\n");
  for (int j = 0; j < kDof; ++j) {
    const Smoothness a = smoothness(g, j, t0, t1), b = smoothness(e, j, t0, t1);
    std::printf("  %5d | %9.4f  %10.4f  %9.2f | %14.3f  %6.3f %8.2f\n", j + 1, a.total_variation,
                b.total_variation, b.total_variation / a.total_variation, a.max_rate, b.max_rate,
                b.max_rate / a.max_rate);
  }
}

}  // namespace

int main(int argc, char** argv) {
  std::string scenario_file, json_file;
  double duration = -1;
  bool audit = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--scenario" && i + 1 < argc) scenario_file = argv[++i];
    else if (a == "--json" && i + 1 < argc) json_file = argv[++i];
    else if (a == "--duration" && i + 1 < argc) duration = std::stod(argv[++i]);
    else if (a == "--no-audit") audit = false;
    else {
      std::fprintf(stderr, "usage: %s [--scenario FILE] [--duration S] [--no-audit] [--json FILE]\n",
                   argv[0]);
      return 2;
    }
  }
  Scenario sc = corridor_scenario();
  if (!scenario_file.empty()) {
    std::ifstream in(scenario_file);
    std::stringstream ss;
    ss << in.rdbuf();
    sc = distlab::server::parse_scenario(distlab::server::parse_json_text(ss.str()), "scenario");
  }
  if (duration > 0) sc.duration = duration;

  RolloutOptions opt;
  opt.audit_clearance = audit;
  const RolloutRecord g = rollout(sc, Metric::gap, opt);
  const RolloutRecord e = rollout(sc, Metric::euclidean, opt);

  std::printf("CBF-QP corridor rollout, %s, %.1f s at dt = %.3f s, %zu pairs, 1 thread\n",
              sc.name.c_str(), sc.duration, sc.dt, g.pairs.size());
  std::printf("  metric     reached  final |r|   min clearance  infeasible  cold | kin us  dist us   qp us  step us | audit us | wall s\n");
  for (const RolloutRecord* r : {&g, &e})
    std::printf("  %-9s  %-7s  %9.2e  %13.5f  %10zu  %4d | %6.2f  %7.2f  %6.2f  %7.2f | %8.2f | %6.3f\n",
                to_string(r->metric), r->reached ? "yes" : "NO", r->final_task_error,
                r->min_clearance, r->infeasible_steps.size(), r->cold_solves,
                r->timing.kinematics, r->timing.distance, r->timing.qp, r->timing.step,
                r->timing.audit, r->wall_seconds);
  const double ratio = g.timing.step / e.timing.step;
  std::printf("  GAP step / Euclidean step = %.2f (target <= 1.3); GAP step %.1f us (target <= 150)\n",
              ratio, g.timing.step);
  std::printf("  35 s rollout wall time: GAP %.3f s, Euclidean %.3f s (target < 1 s; includes the\n"
              "  per-pair record%s)\n", g.wall_seconds, e.wall_seconds,
              audit ? " and the GAP run's Euclidean clearance audit" : "");
  print_smoothness(g, e, 0, 5);
  print_smoothness(g, e, 0, 1e300);

  if (!json_file.empty()) {
    json out;
    for (const RolloutRecord* r : {&g, &e}) {
      out[to_string(r->metric)] = {
          {"reached", r->reached},
          {"final_task_error", r->final_task_error},
          {"min_clearance", r->min_clearance},
          {"infeasible_steps", r->infeasible_steps.size()},
          {"cold_solves", r->cold_solves},
          {"timing_us", {{"kinematics", r->timing.kinematics}, {"distance", r->timing.distance},
                         {"qp", r->timing.qp}, {"step", r->timing.step}, {"audit", r->timing.audit}}},
          {"wall_seconds", r->wall_seconds},
          {"smoothness_0_5s", smooth_json(*r, 0, 5)},
          {"smoothness_all", smooth_json(*r, 0, 1e300)}};
    }
    out["step_ratio_gap_over_euclidean"] = ratio;
    std::ofstream(json_file) << out.dump(2) << "\n";
  }
  return 0;
}
