"""The batch calls on Dask (distlab.batch): 1 against 2 LocalCluster workers, and the cost of a
task against the local path; prints a table and JSON.

  PYTHONPATH=build/python /usr/bin/python3 python/bench/bench_dask.py [--runs 64] [--duration S]
      [--preparations 8] [--lx 0.04] [--only cbf|kelvin|overhead ...] [--json FILE]

Two LocalClusters of worker processes with one thread each (1 and 2 workers), started before any
timing; every kind of task runs once on each first (imports, the robot model, the GAP bodies), then:

1. A corridor sweep of --runs runs (margins.gap.obstacle over a geometric range, the scenario's
   duration unless --duration): locally as sweeps of 16 (the local limit; each on all cores),
   locally one run at a time (the tasks' own calls, in this process), and with client= on 1 and
   on 2 workers.
2. --preparations Kelvin fields (kelvin.prepare_many, each into a fresh cache directory): the four
   built-in meshes scaled to a 1 m bounding-box diagonal and to 1.2 m, at one --lx; locally (one
   after another) and on 1 and 2 workers.
3. The cost of a task: 64 tasks of little work (GAP chunks of 16 pairs; CBF runs of one step)
   against the same 64 calls made locally, the median of --repeat.

Ratios are the result: the machine is shared (its load is printed), seconds are for context only.
"overhead per task" is (1 worker − local, one call after another) / tasks. Each cluster result is
checked equal to the local one (timings aside).
"""

import argparse
import json
import os
import statistics
import sys
import tempfile
import time
import warnings

import numpy as np
from dask.distributed import Client, LocalCluster

import distlab
from distlab import cbf, gap, kelvin

SWEEP_TIMING = "step_us_mean"


def loadavg():
    with open("/proc/loadavg") as f:
        return " ".join(f.read().split()[:3])


def timed(f):
    t0 = time.perf_counter()
    out = f()
    return time.perf_counter() - t0, out


def entries_equal(a, b):
    strip = [{k: v for k, v in e.items() if k != SWEEP_TIMING} for e in a]
    other = [{k: v for k, v in e.items() if k != SWEEP_TIMING} for e in b]
    return repr(strip) == repr(other)


def warm_up(client):
    cbf.sweep("corridor", "duration", [0.01, 0.02], client=client)
    gap.distance(gap.Box([0.2, 0.1, 0.15]), None, gap.Sphere(0.05), np.tile([0.5, 0, 0, 1, 0, 0, 0], (64, 1)),
                 client=client, chunk=16)
    with tempfile.TemporaryDirectory() as d:
        kelvin.prepare_many([os.path.join(distlab.assets_dir, "cube.stl")], lx=0.3, cache_dir=d, client=client)


def bench_cbf(clients, args):
    values = np.geomspace(2e-4, 3e-3, args.runs).tolist()
    params = {} if args.duration is None else {"duration": args.duration}
    t = {}
    t["local_all_cores"], parts = timed(lambda: [cbf.sweep("corridor", "margins.gap.obstacle", values[i:i + 16], "gap",
                                                          params)["entries"] for i in range(0, len(values), 16)])
    local = [dict(e, index=i) for i, e in enumerate(x for p in parts for x in p)]
    t["local_serial"], _ = timed(lambda: [cbf.sweep("corridor", "margins.gap.obstacle", [v], "gap", params)
                                          for v in values])
    for n, client in clients.items():
        t[f"workers_{n}"], out = timed(lambda: cbf.sweep("corridor", "margins.gap.obstacle", values, "gap", params,
                                                         client=client))
        assert entries_equal(out["entries"], local), f"{n} workers: entries differ from the local sweep"
    steps = sum(e["steps"] for e in local)
    return {"tasks": len(values), "steps": steps, "seconds": t}


def surface(path):
    """A mesh file's validated surface (vertices, faces), through a coarse preparation."""
    for lx in (0.2, 0.05, 0.01):
        try:
            return kelvin.Field.prepare(path, lx=lx).surface
        except distlab.InvalidInput as e:  # lx larger than the object: a smaller one
            if e.field != "lx":
                raise
    raise ValueError(f"{path}: no coarse preparation")


def kelvin_meshes(count):
    """count distinct closed surfaces of similar size: the built-in meshes at 1 m and 1.2 m."""
    out = []
    for scale in (1.0, 1.2):
        for name in ("sphere", "cube", "knife", "wrench"):
            V, F = surface(os.path.join(distlab.assets_dir, f"{name}.stl"))
            V = (V - V.mean(axis=0)) * (scale / np.linalg.norm(V.max(axis=0) - V.min(axis=0)))
            out.append((V, F))
    return out[:count]


def bench_kelvin(clients, args):
    meshes = kelvin_meshes(args.preparations)
    t = {}
    with tempfile.TemporaryDirectory() as root:
        t["local_serial"], local = timed(lambda: kelvin.prepare_many(meshes, lx=args.lx, cache_dir=f"{root}/local"))
        for n, client in clients.items():
            t[f"workers_{n}"], out = timed(lambda: kelvin.prepare_many(meshes, lx=args.lx, cache_dir=f"{root}/{n}",
                                                                       client=client))
            assert [s["cache_hit"] for s in out] == [False] * len(meshes)
            assert [s["n_verts"] for s in out] == [s["n_verts"] for s in local], f"{n} workers: other fields"
    return {"tasks": len(meshes), "vertices": [s["n_verts"] for s in local], "seconds": t}


def bench_overhead(clients, args):
    """64 tasks of little work against the same 64 calls made here, median of --repeat."""
    rng = np.random.default_rng(1)
    q = rng.standard_normal((1024, 4))
    poses = np.hstack([rng.uniform(-0.4, 0.4, (1024, 3)) + [0.6, 0, 0], q / np.linalg.norm(q, axis=1, keepdims=True)])
    A, B = gap.Box([0.2, 0.1, 0.15]), gap.Capsule(0.04, 0.1)
    durations = [0.01 * (1 + i % 2) for i in range(64)]  # one or two steps
    kinds = {
        "gap_chunk_16_pairs": (lambda: [gap.distance(A, None, B, poses[i:i + 16], threads=1)
                                        for i in range(0, 1024, 16)],
                               lambda c: gap.distance(A, None, B, poses, client=c, chunk=16)),
        "cbf_run_of_1_or_2_steps": (lambda: [cbf.sweep("corridor", "duration", [d]) for d in durations],
                                    lambda c: cbf.sweep("corridor", "duration", durations, client=c)),
    }
    out = {}
    for name, (here, there) in kinds.items():
        t = {"local_serial": [], **{f"workers_{n}": [] for n in clients}}
        for _ in range(args.repeat):
            t["local_serial"].append(timed(here)[0])
            for n, c in clients.items():
                t[f"workers_{n}"].append(timed(lambda: there(c))[0])
        out[name] = {"tasks": 64, "seconds": {k: statistics.median(v) for k, v in t.items()}}
    return out


def summarize(result):
    s = result["seconds"]
    n = result["tasks"]
    result["ratio_1_to_2_workers"] = s["workers_1"] / s["workers_2"]
    result["overhead_per_task_ms"] = 1e3 * (s["workers_1"] - s["local_serial"]) / n
    if "local_all_cores" in s:
        result["ratio_2_workers_to_local_all_cores"] = s["workers_2"] / s["local_all_cores"]
    return result


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=64)
    ap.add_argument("--duration", type=float, default=None, help="simulated seconds a run (default: the scenario's)")
    ap.add_argument("--preparations", type=int, default=8)
    ap.add_argument("--lx", type=float, default=0.04)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--only", nargs="*", choices=["cbf", "kelvin", "overhead"])
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    only = set(args.only or ["cbf", "kelvin", "overhead"])

    warnings.filterwarnings("ignore", message="Port 8787 is already in use")  # the scheduler's HTTP routes
    report = {"cores": os.cpu_count(), "load_before": loadavg()}
    clusters = {n: LocalCluster(n_workers=n, threads_per_worker=1, processes=True, dashboard_address=None)
                for n in (1, 2)}
    clients = {n: Client(c) for n, c in clusters.items()}
    try:
        for c in clients.values():
            warm_up(c)
        if "cbf" in only:
            report["cbf_sweep"] = summarize(bench_cbf(clients, args))
        if "kelvin" in only:
            report["kelvin_prepare_many"] = summarize(bench_kelvin(clients, args))
        if "overhead" in only:
            report["task_overhead"] = {k: summarize(v) for k, v in bench_overhead(clients, args).items()}
    finally:
        for c in clients.values():
            c.close()
        for c in clusters.values():
            c.close()
    report["load_after"] = loadavg()

    rows = [(name, r) for name, r in report.items() if name in ("cbf_sweep", "kelvin_prepare_many")]
    rows += [(f"task_overhead.{k}", r) for k, r in report.get("task_overhead", {}).items()]
    print(f"load average before {report['load_before']}, after {report['load_after']} ({report['cores']} cores)")
    print(f"{'batch':<40}{'tasks':>6}{'1w/2w':>8}{'2w/local':>10}{'overhead/task':>15}"
          f"{'local 1-by-1':>14}{'1 worker':>10}{'2 workers':>11}")
    for name, r in rows:
        s = r["seconds"]
        local_all = r.get("ratio_2_workers_to_local_all_cores")
        print(f"{name:<40}{r['tasks']:>6}{r['ratio_1_to_2_workers']:>8.2f}"
              f"{(f'{local_all:.2f}' if local_all is not None else '-'):>10}{r['overhead_per_task_ms']:>12.1f} ms"
              f"{s['local_serial']:>12.2f} s{s['workers_1']:>8.2f} s{s['workers_2']:>9.2f} s")
    text = json.dumps(report, indent=1)
    print(text)
    if args.json:
        with open(args.json, "w") as f:
            f.write(text)


if __name__ == "__main__":
    sys.exit(main())
