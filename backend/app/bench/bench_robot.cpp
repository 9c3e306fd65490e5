// distlab-bench-robot (issue 32): every distance of a robot and its gradient in joint space for a
// batch of configurations, robot::distances, against the calls a user would otherwise make.
// The Panda (assets/robots/panda.urdf, 9 collision elements) with the three boxes of
// corridor_narrow (walls and roof), N configurations along the path the built-in GAP controller
// drives towards the slot (the rollout's first N ms, its 10 ms steps resampled linearly to 1 ms;
// the smallest clearance along it is printed), both metrics, the obstacle pairs alone (27) and with the self pairs (52): µs per
// configuration for one thread cold (tracking off: every GAP pair solved from the Euclidean
// start), one thread tracked (each configuration continues from the one before), and two
// threads (cold and tracked; each thread tracks its own contiguous run). The baseline in the same
// run: FK and FCL's distance per pair (collision/euclidean.hpp fcl_distance: no gradients, no
// certification), the call a user of FCL or Coal makes; and FK alone.
// usage: distlab-bench-robot [--n N] [--repeat R] [--assets DIR] [--json FILE] [--save-path FILE]
// --save-path writes the N configurations it times to FILE: N × dof float64, little-endian, raw,
// row-major (python/bench/bench.py times the Python API on them).
// Each case runs R times (default 3), the cases interleaved so that all see the same load; times
// are the medians, wall clock. The load average (/proc/loadavg) is printed before and after.
// Prints a table and one JSON line.
#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <nlohmann/json.hpp>

#include "../src/huge_page_heap.hpp"
#include "distlab/cbf/rollout.hpp"
#include "distlab/cbf/scenario.hpp"
#include "distlab/collision/euclidean.hpp"
#include "distlab/robot/distances.hpp"
#include "distlab/server/cbf_json.hpp"
#include "load_average.hpp"

namespace {

using namespace distlab;
using namespace distlab::robot;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

// The process's CPU time (every thread), µs: steadier than the wall clock on a loaded machine.
double cpu_us() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return 1e6 * static_cast<double>(t.tv_sec) + 1e-3 * static_cast<double>(t.tv_nsec);
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

// The first `seconds` of the corridor_narrow GAP rollout (the built-in controller, dt = 10 ms:
// the arm moves from q0 towards the slot between the walls), resampled linearly to n
// configurations.
std::vector<double> rollout_path(const cbf::Scenario& scene, int n, double seconds) {
  cbf::Scenario sc = scene;
  sc.duration = seconds;
  cbf::RolloutOptions options;
  options.record_pairs = false;
  options.audit_clearance = false;
  const cbf::RolloutRecord r = cbf::rollout(sc, Metric::gap, options);
  std::vector<VecQ> qs;
  for (const cbf::StepRecord& s : r.steps) qs.push_back(s.q);
  qs.push_back(r.q_final);
  const int dof = static_cast<int>(qs.front().size());
  std::vector<double> q(static_cast<std::size_t>(n) * dof);
  for (int s = 0; s < n; ++s) {
    const double x = static_cast<double>(s) * static_cast<double>(qs.size() - 1) / n;
    const auto i = static_cast<std::size_t>(x);
    const double w = x - static_cast<double>(i);
    const VecQ v = (1 - w) * qs[i] + w * qs[i + 1];
    std::copy(v.data(), v.data() + dof, q.begin() + static_cast<std::ptrdiff_t>(s) * dof);
  }
  return q;
}

struct Case {
  Metric metric = Metric::gap;
  bool self = false;
  unsigned threads = 1;
  bool tracking = true;
  const DistanceModel* model = nullptr;
  std::vector<double> us;        // per configuration, one entry per run, wall clock
  std::vector<double> cpu_us;    // the same in the process's CPU time (all threads)
  double iterations = 0;         // GAP: Newton iterations per pair, mean over the batch
  double max_distance_diff = 0;  // Euclidean: |D − FCL's distance| over separated pairs, largest
};

}  // namespace

// A failing benchmark ends on its uncaught exception (std::terminate prints it).
int main(int argc, char** argv) {  // NOLINT(bugprone-exception-escape)
  distlab::app::use_huge_page_heap(argv);
  int n = 10000, repeat = 3;
  std::string assets, json_file, save_path;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--n" && i + 1 < argc) n = std::max(2, std::atoi(argv[++i]));
    else if (a == "--repeat" && i + 1 < argc) repeat = std::max(1, std::atoi(argv[++i]));
    else if (a == "--assets" && i + 1 < argc) assets = argv[++i];
    else if (a == "--json" && i + 1 < argc) json_file = argv[++i];
    else if (a == "--save-path" && i + 1 < argc) save_path = argv[++i];
    else {
      std::fprintf(stderr, "usage: %s [--n N] [--repeat R] [--assets DIR] [--json FILE] [--save-path FILE]\n", argv[0]);
      return 2;
    }
  }
  const std::string load_before = bench::load_average();
  const auto panda = server::load_robot("panda", assets);
  const cbf::Scenario scene = cbf::corridor_narrow_scenario(panda);
  const int dof = panda->dof();
  const double seconds = 1e-3 * n;  // 1 ms per configuration
  const std::vector<double> q = rollout_path(scene, n, seconds);
  if (!save_path.empty()) {
    static_assert(std::endian::native == std::endian::little, "--save-path writes little-endian float64");
    std::ofstream f(save_path, std::ios::binary);
    f.write(reinterpret_cast<const char*>(q.data()), static_cast<std::streamsize>(q.size() * sizeof(double)));
    if (!f) throw std::runtime_error("cannot write " + save_path);
  }

  PairSelection obstacles_only, with_self;
  with_self.self = true;
  const GapParams params = scene.gap;
  const DistanceModel models[2][2] = {
      {DistanceModel(panda, scene.obstacles, Metric::gap, params, obstacles_only),
       DistanceModel(panda, scene.obstacles, Metric::gap, params, with_self)},
      {DistanceModel(panda, scene.obstacles, Metric::euclidean, params, obstacles_only),
       DistanceModel(panda, scene.obstacles, Metric::euclidean, params, with_self)}};
  std::vector<Case> cases;
  for (int m = 0; m < 2; ++m)
    for (int s = 0; s < 2; ++s)
      for (const unsigned threads : {1u, 2u})
        for (const bool tracking : {false, true}) {
          Case c;
          c.metric = m == 0 ? Metric::gap : Metric::euclidean;
          c.self = s == 1;
          c.threads = threads;
          c.tracking = tracking;
          c.model = &models[m][s];
          cases.push_back(c);
        }

  // The baseline: FK, the elements' poses and fcl_distance per pair (of the self model: its
  // pairs are the obstacle pairs, then the self pairs); and FK alone.
  const DistanceModel& all = models[1][1];
  const int obstacle_pairs = static_cast<int>(models[1][0].pairs().size());
  const auto fcl_run = [&](int pairs, std::vector<double>* out) {
    Kinematics k;
    std::vector<Pose> poses(panda->primitives().size());
    double sink = 0;
    const auto t0 = Clock::now();
    for (int c = 0; c < n; ++c) {
      panda->forward(Eigen::Map<const VecQ>(&q[static_cast<std::size_t>(c) * dof], dof), k);
      for (std::size_t i = 0; i < poses.size(); ++i) poses[i] = panda->primitive_pose(k, static_cast<int>(i));
      for (int p = 0; p < pairs; ++p) {
        const RobotPair& pair = all.pairs()[p];
        const EuclideanShape& b = pair.self ? all.robot_shape(pair.b) : all.obstacle_shape(pair.b);
        const Pose& pb = pair.self ? poses[pair.b] : all.obstacles()[pair.b].pose;
        const double d = fcl_distance(all.robot_shape(pair.a), poses[pair.a], b, pb).distance;
        sink += d;
        if (out) out->push_back(d);
      }
    }
    const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count() / n;
    if (!std::isfinite(sink)) std::fprintf(stderr, "non-finite FCL distance\n");
    return us;
  };
  const auto fk_run = [&] {
    Kinematics k;
    double sink = 0;
    const auto t0 = Clock::now();
    for (int c = 0; c < n; ++c) {
      panda->forward(Eigen::Map<const VecQ>(&q[static_cast<std::size_t>(c) * dof], dof), k);
      sink += k.ee.position.x();
    }
    const double us = std::chrono::duration<double, std::micro>(Clock::now() - t0).count() / n;
    if (!std::isfinite(sink)) std::fprintf(stderr, "non-finite FK\n");
    return us;
  };
  std::vector<double> fcl_distances;
  fcl_run(static_cast<int>(all.pairs().size()), &fcl_distances);  // warm-up, and the values to compare with

  std::vector<double> fcl_obstacles_us, fcl_self_us, fk_us;
  for (int r = 0; r < repeat; ++r) {
    for (Case& c : cases) {
      BatchOptions o;
      o.threads = c.threads;
      o.tracking = c.tracking;
      const double c0 = cpu_us();
      const auto t0 = Clock::now();
      const DistanceBatch b = distances(*c.model, q, n, o);
      c.us.push_back(std::chrono::duration<double, std::micro>(Clock::now() - t0).count() / n);
      c.cpu_us.push_back((cpu_us() - c0) / n);
      if (r > 0) continue;
      double it = 0;
      for (int x : b.iterations) it += x;
      c.iterations = b.iterations.empty() ? 0 : it / static_cast<double>(b.iterations.size());
      if (c.metric == Metric::euclidean)
        for (int k = 0; k < n; ++k)
          for (int p = 0; p < b.pairs; ++p) {
            const double mine = b.distance[static_cast<std::size_t>(k) * b.pairs + p];
            const double theirs = fcl_distances[static_cast<std::size_t>(k) * all.pairs().size() + p];
            if (mine > 0 && theirs > 0) c.max_distance_diff = std::max(c.max_distance_diff, std::abs(mine - theirs));
          }
    }
    fcl_obstacles_us.push_back(fcl_run(obstacle_pairs, nullptr));
    fcl_self_us.push_back(fcl_run(static_cast<int>(all.pairs().size()), nullptr));
    fk_us.push_back(fk_run());
  }
  const std::string load_after = bench::load_average();

  // The path's overlaps and smallest distances, obstacle and self pairs (the baseline's values).
  int overlapping = 0;
  double min_obstacle = INFINITY, min_self = INFINITY;
  for (std::size_t i = 0; i < fcl_distances.size(); ++i) {
    const double d = fcl_distances[i];
    overlapping += d <= 0;
    double& m = static_cast<int>(i % all.pairs().size()) < obstacle_pairs ? min_obstacle : min_self;
    m = std::min(m, d);
  }

  std::printf(
      "distlab-bench-robot: Panda (%zu collision elements, %d joints), corridor_narrow's 3 boxes, %d configurations "
      "along the corridor rollout (1 ms steps), median of %d runs, wall clock\n",
      panda->primitives().size(), dof, n, repeat);
  std::printf("  load average (/proc/loadavg, 1/5/15 min): before %s, after %s; %u hardware threads\n", load_before.c_str(),
              load_after.c_str(), std::thread::hardware_concurrency());
  std::printf("  path: %d of %zu pair distances are FCL overlaps; smallest FCL distance %.4f m (obstacle pairs), %.4f m (self)\n\n",
              overlapping, fcl_distances.size(), min_obstacle, min_self);
  std::printf("  wall clock per configuration; CPU: the process's CPU time per configuration, 1 thread\n");
  std::printf("  %-9s  %-18s %3s | %11s  %11s  %11s  %11s | %13s | %16s | %s\n", "metric", "pairs", "P", "1 thr cold",
              "1 thr track", "2 thr cold", "2 thr track", "2 thr speed-up", "CPU cold, track", "Newton it/pair cold, tracked");
  json out_cases = json::array();
  for (std::size_t i = 0; i < cases.size(); i += 4) {
    const Case* c = &cases[i];  // 1 cold, 1 tracked, 2 cold, 2 tracked
    const double t[4] = {median(c[0].us), median(c[1].us), median(c[2].us), median(c[3].us)};
    std::printf("  %-9s  %-18s %3zu | %8.2f us  %8.2f us  %8.2f us  %8.2f us | %6.2f, %5.2f | %7.2f, %6.2f | %.2f, %.2f\n",
                to_string(c->metric), c->self ? "obstacles + self" : "obstacles", c->model->pairs().size(), t[0], t[1],
                t[2], t[3], t[0] / t[2], t[1] / t[3], median(c[0].cpu_us), median(c[1].cpu_us), c[0].iterations,
                c[1].iterations);
    for (int k = 0; k < 4; ++k)
      out_cases.push_back({{"metric", to_string(c[k].metric)},
                           {"pairs", c[k].self ? "obstacles+self" : "obstacles"},
                           {"pair_count", c[k].model->pairs().size()},
                           {"threads", c[k].threads},
                           {"tracking", c[k].tracking},
                           {"us_per_configuration", t[k]},
                           {"runs_us", c[k].us},
                           {"cpu_us_per_configuration", median(c[k].cpu_us)},
                           {"runs_cpu_us", c[k].cpu_us},
                           {"newton_iterations_per_pair", c[k].iterations}});
  }
  const double fcl_o = median(fcl_obstacles_us), fcl_s = median(fcl_self_us), fk = median(fk_us);
  std::printf("\n  baseline, 1 thread: FK + fcl_distance per pair (distance and nearest points; no gradient)\n");
  std::printf("    obstacle pairs %.2f us, with self pairs %.2f us per configuration; FK alone %.2f us\n", fcl_o, fcl_s,
              fk);
  std::printf("  euclidean distances() against the baseline's FCL distances (separated pairs): largest |difference| %.2e m\n",
              std::max(cases[8].max_distance_diff, cases[12].max_distance_diff));
  const double gap_o = median(cases[1].us), gap_s = median(cases[5].us);
  std::printf(
      "  issue 32's targets: GAP tracked, 1 thread: obstacles %.2f us (<= 20), with self %.2f us (<= 50); "
      "2 threads tracked speed-up %.2f and %.2f (>= 1.8)\n",
      gap_o, gap_s, median(cases[1].us) / median(cases[3].us), median(cases[5].us) / median(cases[7].us));
  std::printf("  GAP tracked / FCL baseline: obstacles %.2f, with self %.2f\n", gap_o / fcl_o, gap_s / fcl_s);

  const json result = {{"bench", "robot"},
                       {"robot", "panda"},
                       {"obstacles", "corridor_narrow boxes"},
                       {"path", "corridor_narrow GAP rollout, first " + std::to_string(seconds) + " s at 1 ms"},
                       {"configurations", n},
                       {"repeat", repeat},
                       {"loadavg_before", load_before},
                       {"loadavg_after", load_after},
                       {"hardware_threads", std::thread::hardware_concurrency()},
                       {"overlapping_pair_distances", overlapping},
                       {"min_fcl_distance", {{"obstacles", min_obstacle}, {"self", min_self}}},
                       {"cases", out_cases},
                       {"fcl_baseline_us", {{"obstacles", fcl_o}, {"obstacles+self", fcl_s}, {"fk_only", fk}}}};
  std::printf("%s\n", result.dump().c_str());
  if (!json_file.empty()) std::ofstream(json_file) << result.dump(2) << "\n";
  return 0;
}
