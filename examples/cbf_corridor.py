"""The Panda corridor rollout (paper Fig. 4): joint velocities with GAP and Euclidean distances.
Run: PYTHONPATH=build/python /usr/bin/python3 examples/cbf_corridor.py [--duration 35] [--out DIR]
(or its notebook: examples/notebook.py makes it, options then from $DISTLAB_EXAMPLE_ARGS).
"""

# %%
import argparse
import os

import matplotlib.pyplot as plt
import numpy as np

from distlab import cbf

ap = argparse.ArgumentParser(description="The Panda corridor rollout, GAP against Euclidean")
ap.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the scenario's)")
ap.add_argument("--out", default=".", help="folder for the figure")
args = ap.parse_args()
params = {} if args.duration is None else {"duration": args.duration}

# %% [markdown]
# One rollout per metric (the scenario from the package's assets), progress every 200 steps.

# %%
records = {}
for metric in ("gap", "euclidean"):
    records[metric] = cbf.rollout("corridor", metric, params,
                                  progress=lambda step, t: print(f"\r{metric}: t = {t:.2f} s", end=""), every=200)
    print()

# %%
fig, ax = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
for i, (metric, rec) in enumerate(records.items()):
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
