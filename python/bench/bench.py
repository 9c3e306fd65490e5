"""Benchmarks of distlab from Python, beside the C++ benchmark programs; prints a table and JSON.

  PYTHONPATH=build/python /usr/bin/python3 python/bench/bench.py [--pairs 100000] [--json FILE]

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
"""

import argparse
import json
import os
import pathlib
import subprocess
import tempfile
import time

import numpy as np

from distlab import gap, kelvin

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


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=100_000, help="GAP pairs from Python")
    ap.add_argument("--cases", type=int, default=20, help="polytope pairs (each at pairs/cases poses)")
    ap.add_argument("--cpp-pairs", type=int, default=20_000, help="pairs of the C++ benchmark")
    ap.add_argument("--points", type=int, default=200_000, help="Kelvin query points (about)")
    ap.add_argument("--lx", type=float, default=0.1)
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs")
    ap.add_argument("--bench-gap", default=str(ROOT / "build" / "backend" / "app" / "distlab-bench-gap"))
    ap.add_argument("--json", default=None, help="also write the JSON here")
    args = ap.parse_args()

    g = bench_gap(args, args.bench_gap)
    k = bench_kelvin(args)
    rows = [
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
        ("Kelvin query per point, hints, grid order (CPU)", k["query_us_per_point_hints"], "us"),
        ("Kelvin query per point, no hints, random order (CPU)", k["query_us_per_point_no_hints"], "us"),
    ]
    print(f"GAP: {g['pairs']} pairs; Kelvin: cube, lx {k['lx']}, {k['n_verts']} vertices, {k['points']} points; "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    for name, value, unit in rows:
        print(f"  {name:<64} {value:9.3f} {unit}")
    result = {"gap": g, "kelvin": k}
    print(json.dumps(result, indent=2))
    if args.json:
        with open(args.json, "w") as f:
            json.dump(result, f, indent=2)


if __name__ == "__main__":
    main()
