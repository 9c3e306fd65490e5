"""Benchmarks of distlab from Python, beside the C++ benchmark programs; prints a table and JSON.

  PYTHONPATH=build/python /usr/bin/python3 python/bench/bench.py [--pairs 100000] [--json FILE]
      [--only gap|kelvin|robot ...] [--robot-n 10000]

1. Batched GAP per pair (distlab.gap.distance over N poses) on the pairs of distlab-bench-gap's
   benchmark 1 (10-half-space polytopes, W_i = 1/6, k = 2, h = 0.1, ε = 0.01, σ = 0.989, Newton
   tol 1e-10, no gradient, uncertified GJK start, true distance >= 5 cm): one thread and two
   threads. The polytope pairs are those the C++ program generates (--save-cases); each is
   evaluated at N / cases random poses of B drawn as the C++ program draws them. The C++ program
   then times the same pairs (--load-cases, --newton-only: Newton per pair, and FCL's distance),
   and Python times those too: single-threaded Python/C++ is on identical pairs, both as the
   fastest whole pass in CPU time (the machine is shared). The C++ program's mean of per-pair
   minima over --passes is printed too; it is lower by construction (each pair keeps its luckiest
   pass) and not what a batched caller sees.
2. Kelvin batched query per point (Field.query: one call, GIL released, the points array read in
   place), with and without hints, on a prepared cube, in process CPU time.
3. Robot distances per configuration (issue 32: Python <= 1.1x C++): Robot.load("panda").distances
   with corridor_narrow's three boxes (read from assets/scenarios/corridor_narrow.json, its GAP
   params too) on the configurations distlab-bench-robot times (--save-path, same run, its --json
   beside them), one thread: GAP tracked and cold (tracking=False), Euclidean; obstacle pairs and
   obstacles + self ("both"). Each combination's model is built by a first call (the cache a
   user's batches hit), then the cases run --repeat times interleaved, as the C++ program runs
   them; Python's process CPU time against the C++ program's (the same measure), median and best.
   Also the minor page faults per Python call: the fresh output arrays' first touch, which the C++
   program (reusing its freed heap on one thread) does not pay.
   The work is checked to be the same: finite distances, the Euclidean minima equal to the C++
   program's FCL minima, and the mean Newton iterations per pair equal to the C++ program's.
"""

import argparse
import json
import os
import pathlib
import resource
import subprocess
import tempfile
import time

import numpy as np

from distlab import gap, kelvin
from distlab.robot import Robot

ROOT = pathlib.Path(__file__).resolve().parents[2]


def random_rotations(rng, n):
    q = rng.standard_normal((n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def cpu_and_wall(f, repeat):
    """Best of `repeat` runs: (process CPU seconds, wall seconds). CPU time is what a shared,
    oversubscribed machine cannot inflate for a single thread."""
    cpu = wall = float("inf")
    for _ in range(repeat):
        c0, w0 = time.process_time(), time.perf_counter()
        f()
        cpu, wall = min(cpu, time.process_time() - c0), min(wall, time.perf_counter() - w0)
    return cpu, wall


def bench_gap(args, exe):
    with tempfile.TemporaryDirectory() as tmp:
        cases_path = os.path.join(tmp, "cases.json")
        subprocess.run([exe, "--pairs", str(args.cases), "--newton-only", "--save-cases", cases_path],
                       check=True, capture_output=True)
        cases = json.load(open(cases_path))[: args.cases]
        params = gap.Params(sigma=0.989, gradient=False, validate=False, euclidean=False)
        rng = np.random.default_rng(1)
        per_case = args.pairs // len(cases)
        work = []
        for c in cases:
            a = gap.Polytope(c["a"]["A"], c["a"]["b"], weights=[1 / 6] * 10)
            b = gap.Polytope(c["b"]["A"], c["b"]["b"], weights=[1 / 6] * 10)
            pa = np.array(c["a"]["position"] + c["a"]["quaternion"])
            # B's poses as the C++ program draws them: uniform in [-0.5, 0.5]^3, random rotation,
            # kept when the true distance is at least 5 cm.
            poses = np.empty((0, 7))
            while len(poses) < per_case:
                cand = np.hstack([rng.uniform(-0.5, 0.5, (2 * per_case, 3)), random_rotations(rng, 2 * per_case)])
                d = gap.distance(a, pa, b, cand, gap.Params(sigma=0.989, gradient=False, validate=False)).euclidean_distance
                poses = np.vstack([poses, cand[d >= 0.05]])
            work.append((a, pa, b, np.ascontiguousarray(poses[:per_case]), c))
        n = per_case * len(work)

        # The C++ benchmark on the first cpp_per_case poses of each pair, in the same order (one
        # polytope pair after the other, as the Python batches run): --load-cases of exactly these.
        cpp_per_case = min(per_case, args.cpp_pairs // len(work))
        same = []
        for _, _, _, poses, c in work:
            for p in poses[:cpp_per_case]:
                same.append({"a": c["a"], "b": dict(c["b"], position=p[:3].tolist(), quaternion=p[3:].tolist())})
        same_path, json_path = os.path.join(tmp, "same.json"), os.path.join(tmp, "gap.json")
        with open(same_path, "w") as f:
            json.dump(same, f)
        subprocess.run([exe, "--newton-only", "--passes", str(args.repeat), "--load-cases", same_path,
                        "--json", json_path], check=True, capture_output=True)
        cpp = json.load(open(json_path))

    def run(threads, count=None):
        for a, pa, b, poses, _ in work:
            gap.distance(a, pa, b, poses[:count], params, threads=threads)

    cpu1, wall1 = cpu_and_wall(lambda: run(1), args.repeat)
    cpu2, wall2 = cpu_and_wall(lambda: run(2), args.repeat)
    cpu_same, _ = cpu_and_wall(lambda: run(1, cpp_per_case), args.repeat)
    m = cpp_per_case * len(work)
    newton = cpp["newton_tol_1e-10"]["time_us"]
    return {"pairs": n, "python_1_thread_cpu_us_per_pair": cpu1 / n * 1e6,
            "python_1_thread_wall_us_per_pair": wall1 / n * 1e6,
            "python_2_threads_wall_us_per_pair": wall2 / n * 1e6, "throughput_2_threads_over_1": wall1 / wall2,
            "cpu_2_threads_over_1": cpu2 / cpu1,
            "same_pairs": m, "python_same_pairs_cpu_us_per_pair": cpu_same / m * 1e6,
            "cpp_newton_us_per_pair_mean": newton["mean"], "cpp_newton_us_per_pair_median": newton["median"],
            "cpp_newton_batch_cpu_us_per_pair": cpp["newton_batch_cpu_us_per_pair"],
            "python_over_cpp": cpu_same / m * 1e6 / cpp["newton_batch_cpu_us_per_pair"],
            "python_over_cpp_per_pair_minima": cpu_same / m * 1e6 / newton["mean"],
            "fcl_distance_us_per_pair_mean": cpp["fcl"]["time_us"]["mean"]}


def bench_kelvin(args):
    field = kelvin.Field.prepare(ROOT / "assets" / "cube.stl", lx=args.lx)
    field.set_sigma(constant=0.2)
    rng = np.random.default_rng(2)
    # Coherent order (as a slice or a grid is queried): points along lines; random order without hints.
    m = int(round(args.points ** (1 / 3)))
    g = np.linspace(-1.5, 1.5, m)
    grid = np.stack(np.meshgrid(g, g, g, indexing="ij"), axis=-1).reshape(-1, 3)
    grid = grid[np.abs(grid).max(axis=1) > 0.6]
    shuffled = grid[rng.permutation(len(grid))]
    with_hints = cpu_and_wall(lambda: field.query(grid, hints=True), args.repeat)[0] / len(grid) * 1e6
    without = cpu_and_wall(lambda: field.query(shuffled, hints=False), args.repeat)[0] / len(grid) * 1e6
    return {"points": len(grid), "lx": args.lx, "n_verts": field.stats["n_verts"],
            "query_us_per_point_hints": with_hints, "query_us_per_point_no_hints": without}


def bench_robot(args, exe):
    scenario = json.load(open(ROOT / "assets" / "scenarios" / "corridor_narrow.json"))
    # The scenario lists {"name", "shape": {type, size, pose}}; distances() takes shape dicts with a "name".
    obstacles = [dict(o["shape"], name=o["name"]) for o in scenario["obstacles"]]
    params = scenario["gap"]
    robot = Robot.load(scenario["robot"])
    load_before = os.getloadavg()
    with tempfile.TemporaryDirectory() as tmp:
        q_path, json_path = os.path.join(tmp, "q.f64"), os.path.join(tmp, "robot.json")
        subprocess.run([exe, "--n", str(args.robot_n), "--repeat", str(args.repeat), "--assets", str(ROOT / "assets"),
                        "--save-path", q_path, "--json", json_path], check=True, capture_output=True)
        q = np.fromfile(q_path, dtype="<f8")
        cpp = json.load(open(json_path))
    n = cpp["configurations"]
    assert q.size == n * robot.dof, (q.size, n, robot.dof)
    q = q.reshape(n, robot.dof)

    # (metric, pairs, tracking): the C++ program's 1-thread cases (Euclidean has nothing to track).
    cases = [(m, p, t) for m in ("gap", "euclidean") for p in ("obstacles", "both")
             for t in ((True, False) if m == "gap" else (True,))]

    def run(case):
        m, p, t = case
        return robot.distances(q, obstacles, metric=m, pairs=p, params=params, threads=1, tracking=t)

    for m in ("gap", "euclidean"):  # build each model once (validate included), as a user's first call does
        for p in ("obstacles", "both"):
            robot.distances(q[:2], obstacles, metric=m, pairs=p, params=params, threads=1)
    cpu = {c: [] for c in cases}
    faults = {c: [] for c in cases}
    results = {}
    for r in range(args.repeat):  # interleaved, so that every case sees the same load
        for c in cases:
            f0 = resource.getrusage(resource.RUSAGE_SELF).ru_minflt
            c0 = time.process_time()
            d = run(c)
            cpu[c].append((time.process_time() - c0) / n * 1e6)
            faults[c].append(resource.getrusage(resource.RUSAGE_SELF).ru_minflt - f0)
            if r == 0:
                results[c] = d
    load_after = os.getloadavg()

    # The same work: finite; the Euclidean minima are the C++ program's FCL minima (the same pairs:
    # obstacle pairs first, then the self pairs); Newton iterations as the C++ program's.
    for c, d in results.items():
        assert np.isfinite(d.distance).all() and np.isfinite(d.jacobian).all(), c
    n_obstacle_pairs = results[("euclidean", "obstacles", True)].distance.shape[1]
    e = results[("euclidean", "both", True)].distance
    min_e = {"obstacles": float(e[:, :n_obstacle_pairs].min()), "self": float(e[:, n_obstacle_pairs:].min())}
    min_fcl = cpp["min_fcl_distance"]
    min_diff = max(abs(min_e[k] - min_fcl[k]) for k in min_e)
    if cpp["overlapping_pair_distances"] == 0:
        assert min_diff < 1e-6, (min_e, min_fcl)
    g = results[("gap", "both", True)].distance
    min_gap = {"obstacles": float(g[:, :n_obstacle_pairs].min()), "self": float(g[:, n_obstacle_pairs:].min())}
    tracked_vs_cold = max(float(np.abs(results[("gap", p, True)].distance - results[("gap", p, False)].distance).max())
                          for p in ("obstacles", "both"))

    def cpp_case(m, p, t):
        name = "obstacles+self" if p == "both" else p
        (x,) = [x for x in cpp["cases"]
                if x["metric"] == m and x["pairs"] == name and x["threads"] == 1 and x["tracking"] == t]
        return x

    rows = []
    for c in cases:
        x = cpp_case(*c)
        py_med, py_best = float(np.median(cpu[c])), min(cpu[c])
        cpp_med, cpp_best = x["cpu_us_per_configuration"], min(x.get("runs_cpu_us", [x["cpu_us_per_configuration"]]))
        rows.append({"metric": c[0], "pairs": c[1], "tracking": c[2], "pair_count": results[c].distance.shape[1],
                     "python_cpu_us_per_configuration": py_med, "python_cpu_us_best": py_best,
                     "python_runs_cpu_us": cpu[c], "python_minor_page_faults_per_call": int(np.median(faults[c])),
                     "cpp_cpu_us_per_configuration": cpp_med, "cpp_cpu_us_best": cpp_best,
                     "cpp_wall_us_per_configuration": x["us_per_configuration"],
                     "python_over_cpp": py_med / cpp_med, "python_over_cpp_best": py_best / cpp_best,
                     "python_newton_iterations_per_pair": float(results[c].iterations.mean()),
                     "cpp_newton_iterations_per_pair": x["newton_iterations_per_pair"]})
    return {"configurations": n, "repeat": args.repeat, "threads": 1, "params": params,
            "loadavg_before": load_before, "loadavg_after": load_after,
            "cpp_loadavg_before": cpp["loadavg_before"], "cpp_loadavg_after": cpp["loadavg_after"],
            "min_euclidean": min_e, "min_fcl_cpp": min_fcl, "min_euclidean_minus_fcl_max": min_diff,
            "cpp_overlapping_pair_distances": cpp["overlapping_pair_distances"], "min_gap": min_gap,
            "gap_tracked_minus_cold_max": tracked_vs_cold, "cases": rows}


def print_robot(r):
    print(f"Robot distances: Panda, corridor_narrow's 3 boxes, {r['configurations']} configurations of "
          f"distlab-bench-robot's path (same run), 1 thread, process CPU time per configuration, "
          f"median (best) of {r['repeat']} interleaved runs")
    print("  load average (1/5/15 min): Python before {:.2f} {:.2f} {:.2f}, after {:.2f} {:.2f} {:.2f}; "
          "C++ before {}, after {}; {} cores".format(*r["loadavg_before"], *r["loadavg_after"],
                                                     r["cpp_loadavg_before"], r["cpp_loadavg_after"], os.cpu_count()))
    print(f"  {'metric':<9} {'pairs':<10} {'P':>3} {'mode':<8} | {'Python us':>17} | {'C++ us':>17} | "
          f"{'Python/C++':>13} | {'faults/call':>11} | Newton it/pair Py, C++")
    for c in r["cases"]:
        mode = ("tracked" if c["tracking"] else "cold") if c["metric"] == "gap" else "-"
        print(f"  {c['metric']:<9} {c['pairs']:<10} {c['pair_count']:>3} {mode:<8} | "
              f"{c['python_cpu_us_per_configuration']:7.2f} ({c['python_cpu_us_best']:7.2f}) | "
              f"{c['cpp_cpu_us_per_configuration']:7.2f} ({c['cpp_cpu_us_best']:7.2f}) | "
              f"{c['python_over_cpp']:5.3f} ({c['python_over_cpp_best']:5.3f}) | "
              f"{c['python_minor_page_faults_per_call']:>11} | "
              f"{c['python_newton_iterations_per_pair']:.4f}, {c['cpp_newton_iterations_per_pair']:.4f}")
    print(f"  checks: distances and Jacobians finite; smallest Euclidean distance, obstacle pairs / self pairs: "
          f"Python {r['min_euclidean']['obstacles']:.6f} / {r['min_euclidean']['self']:.6f} m, C++ FCL "
          f"{r['min_fcl_cpp']['obstacles']:.6f} / {r['min_fcl_cpp']['self']:.6f} m "
          f"(largest difference {r['min_euclidean_minus_fcl_max']:.1e}); smallest GAP D "
          f"{r['min_gap']['obstacles']:.6f} / {r['min_gap']['self']:.6f}; "
          f"GAP tracked - cold, largest |difference| {r['gap_tracked_minus_cold_max']:.1e}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=100_000, help="GAP pairs from Python")
    ap.add_argument("--cases", type=int, default=20, help="polytope pairs (each at pairs/cases poses)")
    ap.add_argument("--cpp-pairs", type=int, default=20_000, help="pairs of the C++ benchmark")
    ap.add_argument("--points", type=int, default=200_000, help="Kelvin query points (about)")
    ap.add_argument("--lx", type=float, default=0.1)
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    ap.add_argument("--robot-n", type=int, default=10_000, help="robot configurations (distlab-bench-robot --n)")
    ap.add_argument("--bench-gap", default=str(ROOT / "build" / "backend" / "app" / "distlab-bench-gap"))
    ap.add_argument("--bench-robot", default=str(ROOT / "build" / "backend" / "app" / "distlab-bench-robot"))
    ap.add_argument("--only", action="append", choices=["gap", "kelvin", "robot"],
                    help="run only this section (repeatable; default all)")
    ap.add_argument("--json", default=None, help="also write the JSON here")
    args = ap.parse_args()
    only = set(args.only or ["gap", "kelvin", "robot"])

    result = {}
    if only & {"gap", "kelvin"}:
        print_gap_kelvin(args, only, result)
    if "robot" in only:
        result["robot"] = bench_robot(args, args.bench_robot)
        print_robot(result["robot"])
    print(json.dumps(result, indent=2))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=2)


def print_gap_kelvin(args, only, result):
    rows = []
    if "gap" in only:
        g = result["gap"] = bench_gap(args, args.bench_gap)
        rows += [
            ("GAP Newton per pair, Python batched, 1 thread (CPU)", g["python_1_thread_cpu_us_per_pair"], "us"),
            ("  the same, wall time", g["python_1_thread_wall_us_per_pair"], "us"),
            ("  2 threads, wall time", g["python_2_threads_wall_us_per_pair"], "us"),
            ("  throughput 2 threads / 1 thread (wall)", g["throughput_2_threads_over_1"], "x"),
            ("  CPU time 2 threads / 1 thread (1: no parallel overhead)", g["cpu_2_threads_over_1"], "x"),
            (f"GAP Newton per pair, same {g['same_pairs']} pairs: Python (CPU)", g["python_same_pairs_cpu_us_per_pair"], "us"),
            ("  C++ distlab-bench-gap, whole pass as one (CPU), fastest pass", g["cpp_newton_batch_cpu_us_per_pair"], "us"),
            ("  Python / C++ (both: a whole pass, CPU time, fastest)", g["python_over_cpp"], "x"),
            ("  C++ distlab-bench-gap, mean of per-pair minima", g["cpp_newton_us_per_pair_mean"], "us"),
            ("  Python / C++ per-pair minima (not like for like)", g["python_over_cpp_per_pair_minima"], "x"),
            ("FCL distance per pair (C++, same pairs), mean", g["fcl_distance_us_per_pair_mean"], "us"),
        ]
    if "kelvin" in only:
        k = result["kelvin"] = bench_kelvin(args)
        rows += [
            ("Kelvin query per point, hints, grid order (CPU)", k["query_us_per_point_hints"], "us"),
            ("Kelvin query per point, no hints, random order (CPU)", k["query_us_per_point_no_hints"], "us"),
        ]
    what = []
    if "gap" in result:
        what.append(f"GAP: {result['gap']['pairs']} pairs")
    if "kelvin" in result:
        k = result["kelvin"]
        what.append(f"Kelvin: cube, lx {k['lx']}, {k['n_verts']} vertices, {k['points']} points")
    print(f"{'; '.join(what)}; load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    for name, value, unit in rows:
        print(f"  {name:<64} {value:9.3f} {unit}")


if __name__ == "__main__":
    main()
