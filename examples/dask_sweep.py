"""A sweep of GAP distances over many random poses on a dask.distributed cluster.

``gap.distance(..., client=)`` sends the poses to the workers of a LocalCluster (or of a running
cluster: --scheduler tcp://host:8786) in chunks of --chunk pairs, each chunk one batched call, and
returns one Result in the poses' order (the local call's numbers, bit for bit); progress is printed
as the pairs get done; the figure shows GAP's D against the Euclidean distance.
Run: PYTHONPATH=build/python /usr/bin/python3 examples/dask_sweep.py [--pairs 1000000] [--out DIR]
"""

import argparse
import os
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from dask.distributed import Client, LocalCluster  # noqa: E402

from distlab import gap  # noqa: E402


def random_poses(n, seed=0):
    """n random poses of a capsule around a box: positions in a 0.8 m cube, uniform rotations."""
    rng = np.random.default_rng(seed)
    q = rng.standard_normal((n, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return np.hstack([rng.uniform(-0.4, 0.4, (n, 3)), q])


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--pairs", type=int, default=1_000_000)
    ap.add_argument("--chunk", type=int, default=None, help="pairs per task (default: about 512 kB of poses)")
    ap.add_argument("--workers", type=int, default=2, help="LocalCluster workers (without --scheduler)")
    ap.add_argument("--scheduler", default=None, help="address of a running scheduler, e.g. tcp://host:8786")
    ap.add_argument("--out", default=".")
    args = ap.parse_args()

    cluster = None
    if args.scheduler:
        client = Client(args.scheduler)
    else:
        cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, dashboard_address=None)
        client = Client(cluster)
    poses = random_poses(args.pairs)

    def progress(done, total):
        print(f"\r{done}/{total} pairs", end="", flush=True)

    t0 = time.perf_counter()
    r = gap.distance(gap.Box([0.2, 0.1, 0.15]), None, gap.Capsule(0.04, 0.1), poses, gap.Params(gradient=False),
                     client=client, chunk=args.chunk, progress=progress)
    seconds = time.perf_counter() - t0
    print(f"\n{args.pairs} pairs in {seconds:.2f} s ({1e6 * seconds / args.pairs:.2f} us per pair, all workers)")
    client.close()
    if cluster is not None:
        cluster.close()
    D, E = r.distance, r.euclidean_distance
    assert len(D) == args.pairs and np.isfinite(D).all()
    fig, ax = plt.subplots(figsize=(6, 5))
    ax.plot(E, D, ",", alpha=0.3)
    ax.set_xlabel("Euclidean distance (m)")
    ax.set_ylabel("GAP D (m)")
    ax.set_title(f"{args.pairs} random poses, box–capsule")
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "dask_sweep.png")
    fig.savefig(path, dpi=120)
    print(path)


if __name__ == "__main__":
    main()
