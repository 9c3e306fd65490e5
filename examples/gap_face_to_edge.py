"""GAP against the Euclidean distance along a path from face contact to edge contact.

A box slides past the corner of another one: first its face faces the other's face (the
Euclidean nearest points jump along a whole face), then the nearest feature becomes an edge. The
GAP distance D and its gradient stay smooth; the Euclidean gradient switches direction abruptly.
Run: PYTHONPATH=build/python /usr/bin/python3 examples/gap_face_to_edge.py [--n 400] [--out DIR]
(or its notebook: examples/notebook.py makes it, options then from $DISTLAB_EXAMPLE_ARGS).
"""

# %%
import argparse
import os

import matplotlib.pyplot as plt
import numpy as np

from distlab import gap

ap = argparse.ArgumentParser(description="GAP against Euclidean from face to edge contact")
ap.add_argument("--n", type=int, default=400, help="poses along the path")
ap.add_argument("--out", default=".", help="folder for the figure")
args = ap.parse_args()

# %% [markdown]
# B (a 0.1 m cube) at x = 0.2, a 0.05 m gap to A's +x face, slides along y past A's edge and
# around it; one batched call gives D, the witnesses and the pose gradients of all poses.

# %%
a = gap.Box([0.2, 0.2, 0.2])
b = gap.Box([0.1, 0.1, 0.1])
s = np.linspace(0.0, 0.35, args.n)
poses = np.zeros((args.n, 7))
poses[:, 0] = 0.2
poses[:, 1] = s
poses[:, 3] = 1.0
r = gap.distance(a, None, b, poses)
dD = r.gradient_b[:, 1]  # dD/dy of B: along the path
dE = r.euclidean_gradient_b[:, 1]

# %%
fig, ax = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
ax[0].plot(s, r.distance, label="GAP D")
ax[0].plot(s, r.euclidean_distance, "--", label="Euclidean")
ax[0].set_ylabel("distance (m)")
ax[0].axvline(0.15, color="grey", lw=0.5)
ax[0].legend()
ax[1].plot(s, dD, label="GAP dD/ds (exact gradient)")
ax[1].plot(s[1:-1], (r.distance[2:] - r.distance[:-2]) / (s[2:] - s[:-2]), ":", label="GAP finite difference")
ax[1].plot(s, dE, "--", label="Euclidean d/ds")
ax[1].set_xlabel("s: B's offset along y (m); face → edge at s = 0.15")
ax[1].set_ylabel("derivative")
ax[1].legend()
fig.tight_layout()
os.makedirs(args.out, exist_ok=True)
path = os.path.join(args.out, "gap_face_to_edge.png")
fig.savefig(path, dpi=120)

# %% [markdown]
# Continuity in numbers: the largest jump of the derivative between neighbouring poses, and the
# exact gradient against a central finite difference of D.

# %%
print(f"max |Δ dD/ds| GAP {np.abs(np.diff(dD)).max():.4f}, Euclidean {np.abs(np.diff(dE)).max():.4f}; {path}")
fd = (r.distance[2:] - r.distance[:-2]) / (s[2:] - s[:-2])
assert np.allclose(fd, dD[1:-1], atol=5e-3), "GAP gradient disagrees with its finite difference"
