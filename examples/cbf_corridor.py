"""The Panda corridor rollout (paper Fig. 4): joint velocities with GAP and Euclidean distances.
Run: PYTHONPATH=build/python /usr/bin/python3 examples/cbf_corridor.py [--duration 35] [--out DIR]
"""

import argparse
import os

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from distlab import cbf  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the scenario's)")
    ap.add_argument("--out", default=".", help="folder for the figure")
    args = ap.parse_args()
    params = {} if args.duration is None else {"duration": args.duration}

    fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
    for i, metric in enumerate(("gap", "euclidean")):
        rec = cbf.rollout("corridor", metric, params,
                          progress=lambda step, t: print(f"\r{metric}: t = {t:.2f} s", end=""), every=200)
        print()
        for j in range(7):
            ax[i].plot(rec["t"], rec["u"][:, j], lw=1, label=f"joint {j + 1}")
        tv = rec["smoothness"]["total_variation"]
        ax[i].set_title(f"{metric}: Σ|Δu| = {np.sum(tv):.3f} rad/s, reached {rec['summary']['reached']}")
        ax[i].set_ylabel("u (rad/s)")
    ax[1].set_xlabel("t (s)")
    ax[0].legend(ncol=4, fontsize=7)
    fig.tight_layout()
    os.makedirs(args.out, exist_ok=True)
    path = os.path.join(args.out, "cbf_corridor.png")
    fig.savefig(path, dpi=120)
    print(path)


if __name__ == "__main__":
    main()
