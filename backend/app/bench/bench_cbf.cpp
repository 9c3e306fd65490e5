// distlab-bench-cbf: the corridor experiment (paper Section IV-B) with both metrics in one run:
// goal reached?, true clearance, smoothness of u per joint (paper Fig. 4), per-step times.
// usage: distlab-bench-cbf [--scenario NAME|FILE] [--params JSON] [--duration S] [--repeat N]
//                          [--no-audit] [--json FILE]
// NAME: assets/scenarios/NAME.json (default corridor_narrow); --params: the request's "params"
// (e.g. '{"gap": {"mode": "as_published", "tol": 2e-4, "max_iter": 300}}'), applied to both
// metrics.
// With --repeat N the two metrics run N times each, alternating (so both see the same machine
// load), and the times are medians over the runs; "step p50" is the median step of a run.
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <iostream>
#include <sstream>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "../src/huge_page_heap.hpp"
#include "distlab/cbf/rollout.hpp"
#include "distlab/server/cbf_json.hpp"

namespace {

using namespace distlab::cbf;
using nlohmann::json;

json smooth_json(const RolloutRecord& r, double t0, double t1) {
  json tv = json::array(), rate = json::array();
  for (int j = 0; j < r.q_final.size(); ++j) {
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
  for (int j = 0; j < g.q_final.size(); ++j) {
    const Smoothness a = smoothness(g, j, t0, t1), b = smoothness(e, j, t0, t1);
    std::printf("  %5d | %9.4f  %10.4f  %9.2f | %14.3f  %6.3f %8.2f\n", j + 1, a.total_variation,
                b.total_variation, b.total_variation / a.total_variation, a.max_rate, b.max_rate,
                b.max_rate / a.max_rate);
  }
}

struct RunTimes {
  double kinematics, distance, qp, step, audit, wall, step_p50;
};

RunTimes run_times(const RolloutRecord& r) {
  std::vector<double> steps;
  for (const StepRecord& s : r.steps) steps.push_back(s.timing.step);
  std::nth_element(steps.begin(), steps.begin() + steps.size() / 2, steps.end());
  return {r.timing.kinematics, r.timing.distance, r.timing.qp, r.timing.step, r.timing.audit, r.wall_seconds,
          steps.empty() ? 0.0 : steps[steps.size() / 2]};
}

double median_of(std::vector<RunTimes> runs, double RunTimes::*field) {
  std::sort(runs.begin(), runs.end(), [&](const RunTimes& a, const RunTimes& b) { return a.*field < b.*field; });
  const std::size_t n = runs.size();
  return n % 2 ? runs[n / 2].*field : 0.5 * (runs[n / 2 - 1].*field + runs[n / 2].*field);
}

}  // namespace

// A failing benchmark ends on its uncaught exception (std::terminate prints it).
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  distlab::app::use_huge_page_heap(argv);
  std::string scenario_file = "corridor_narrow", json_file, params = "{}";
  double duration = -1;
  int repeat = 1;
  bool audit = true;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--scenario" && i + 1 < argc) scenario_file = argv[++i];
    else if (a == "--json" && i + 1 < argc) json_file = argv[++i];
    else if (a == "--params" && i + 1 < argc) params = argv[++i];
    else if (a == "--duration" && i + 1 < argc) duration = std::stod(argv[++i]);
    else if (a == "--repeat" && i + 1 < argc) repeat = std::max(1, std::atoi(argv[++i]));
    else if (a == "--no-audit") audit = false;
    else {
      std::fprintf(stderr,
                   "usage: %s [--scenario NAME|FILE] [--params JSON] [--duration S] [--repeat N] [--no-audit] "
                   "[--json FILE]\n",
                   argv[0]);
      return 2;
    }
  }
  Scenario sc;
  try {
    json scenario = scenario_file;
    if (scenario_file.find('/') != std::string::npos || scenario_file.find(".json") != std::string::npos) {
      std::ifstream in(scenario_file);
      std::stringstream ss;
      ss << in.rdbuf();
      scenario = distlab::server::parse_json_text(ss.str());
    }
    sc = distlab::server::parse_cbf_request(
             {{"scenario", scenario}, {"params", distlab::server::parse_json_text(params)}})
             .scenario;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "%s: %s\n", argv[0], e.what());
    return 2;
  }
  if (duration > 0) sc.duration = duration;

  RolloutOptions opt;
  opt.audit_clearance = audit;
  // Timings of every run; the records of the last run of each metric (the numbers do not change
  // between runs, only the times).
  RolloutRecord g, e;
  std::vector<RunTimes> gt, et;
  for (int k = 0; k < repeat; ++k) {
    g = rollout(sc, Metric::gap, opt);
    gt.push_back(run_times(g));
    e = rollout(sc, Metric::euclidean, opt);
    et.push_back(run_times(e));
  }
  for (auto* p : {&g, &e}) {  // medians over the runs in place of the last run's means
    const std::vector<RunTimes>& t = p == &g ? gt : et;
    p->timing.kinematics = median_of(t, &RunTimes::kinematics);
    p->timing.distance = median_of(t, &RunTimes::distance);
    p->timing.qp = median_of(t, &RunTimes::qp);
    p->timing.step = median_of(t, &RunTimes::step);
    p->timing.audit = median_of(t, &RunTimes::audit);
    p->wall_seconds = median_of(t, &RunTimes::wall);
  }
  const double g_p50 = median_of(gt, &RunTimes::step_p50), e_p50 = median_of(et, &RunTimes::step_p50);

  std::printf(
      "CBF-QP corridor rollout, %s, %.1f s at dt = %.3f s, %zu pairs, 1 thread, %d run(s) per metric "
      "(times: medians over runs of the per-run mean)\n",
      sc.name.c_str(), sc.duration, sc.dt, g.pairs.size(), repeat);
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
  std::printf("  median step (p50 within a run, median over runs): GAP %.1f us, Euclidean %.1f us\n", g_p50,
              e_p50);
  std::printf(
      "  35 s rollout wall time: GAP %.3f s, Euclidean %.3f s (target < 1 s; includes the\n"
      "  per-pair record%s)\n",
      g.wall_seconds, e.wall_seconds,
      audit ? " and the GAP run's Euclidean clearance audit" : "");
  for (const RolloutRecord* r : {&g, &e}) {
    const FinalState& f = r->final_state;
    std::printf(
        "  %-9s ends at (%.4f, %.4f, %.4f), |p - p_d| = %.2f cm, min clearance there %.2f cm (%s), "
        "clipped steps %d\n",
        to_string(r->metric), f.ee_position.x(), f.ee_position.y(), f.ee_position.z(),
        100 * f.position_error, 100 * f.min_clearance, f.closest_pair.c_str(), r->clipped_steps);
    for (std::size_t k = 0; k < std::min<std::size_t>(f.active.size(), 4); ++k) {
      const ActiveConstraint& a = f.active[k];
      std::printf("    active %-26s D %.6f  delta %.6f  clearance %.4f  multiplier %.3g", a.name.c_str(), a.distance,
                  a.margin, a.clearance, a.multiplier);
      if (std::isfinite(a.converged_distance)) std::printf("  converged D %.6f", a.converged_distance);
      std::printf("\n");
    }
  }
  double tv_g = 0, tv_e = 0, tv_g57 = 0, tv_e57 = 0;
  for (int j = 0; j < g.q_final.size(); ++j) {
    const double a = smoothness(g, j).total_variation, b = smoothness(e, j).total_variation;
    tv_g += a, tv_e += b;
    if (j >= 4) tv_g57 += a, tv_e57 += b;
  }
  std::printf("  total variation of u: GAP %.3f (joints 5-7 %.3f), Euclidean %.3f (joints 5-7 %.3f)\n", tv_g, tv_g57,
              tv_e, tv_e57);
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
          {"final", distlab::server::encode_final_state(r->final_state)},
          {"timing_us", {{"kinematics", r->timing.kinematics}, {"distance", r->timing.distance}, {"qp", r->timing.qp}, {"step", r->timing.step}, {"audit", r->timing.audit}}},
          {"wall_seconds", r->wall_seconds},
          {"smoothness_0_5s", smooth_json(*r, 0, 5)},
          {"smoothness_all", smooth_json(*r, 0, 1e300)}};
    }
    out["step_ratio_gap_over_euclidean"] = ratio;
    out["repeat"] = repeat;
    out["gap"]["step_p50_us"] = g_p50;
    out["euclidean"]["step_p50_us"] = e_p50;
    std::ofstream(json_file) << out.dump(2) << "\n";
  }
  return 0;
}
