"""The Kelvin field around a sphere: σ painted on half of it, a slice of h with the zero level set,
and constant σ against the closed form h = σ + ln(|x| / R).
Run: PYTHONPATH=build/python /usr/bin/python3 examples/kelvin_sphere_slice.py [--lx 0.1] [--out DIR]
(or its notebook: examples/notebook.py makes it, options then from $DISTLAB_EXAMPLE_ARGS).
"""

# %%
import argparse
import os

import matplotlib.pyplot as plt
import numpy as np

import distlab
from distlab import kelvin

ap = argparse.ArgumentParser(description="The Kelvin field around a sphere")
ap.add_argument("--lx", type=float, default=0.08, help="exterior element size (m)")
ap.add_argument("--grid", type=int, default=160, help="slice resolution")
ap.add_argument("--out", default=".", help="folder for the figure")
args = ap.parse_args()

# %% [markdown]
# Prepare once (σ-independent), then σ = 0.4 on the half x > 0 and −0.3 on the other (per vertex,
# in the file's order): the zero level set leaves the surface on the negative half.

# %%
R = 0.5
field = kelvin.Field.prepare(os.path.join(distlab.assets_dir, "sphere.stl"), lx=args.lx,
                             center=[0.05, -0.03, 0.02], progress=lambda stage, f: None)
V, _ = field.surface
field.set_sigma(per_vertex=np.where(V[:, 0] > 0, 0.4, -0.3))
g = np.linspace(-1.5, 1.5, args.grid)
X, Y = np.meshgrid(g, g)
pts = np.stack([X.ravel(), Y.ravel(), np.zeros(X.size)], axis=1)
h, _, _ = field.query(pts)
H = h.reshape(X.shape)

# %% [markdown]
# Constant σ: the closed form along a ray.

# %%
field.set_sigma(constant=0.3)
r = np.linspace(0.55, 1.5, 200)
hr, _, _ = field.query(np.stack([r, 0 * r, 0 * r], axis=1))
exact = 0.3 + np.log(r / R)

# %%
fig, ax = plt.subplots(1, 2, figsize=(11, 4.5))
im = ax[0].pcolormesh(X, Y, H, shading="auto", cmap="viridis")
ax[0].contour(X, Y, np.ma.masked_invalid(H), levels=[0.0], colors="red")
ax[0].add_patch(plt.Circle((0, 0), R, fill=False, color="white"))
ax[0].set_aspect("equal")
ax[0].set_title("h on z = 0; σ 0.4 (x > 0), −0.3 (x < 0); red: h = 0", fontsize=9)
fig.colorbar(im, ax=ax[0])
ax[1].plot(r, hr, label="Kelvin field, σ = 0.3")
ax[1].plot(r, exact, "--", label="σ + ln(r / R)")
ax[1].set_xlabel("r (m)")
ax[1].set_ylabel("h")
ax[1].legend()
fig.tight_layout()
os.makedirs(args.out, exist_ok=True)
path = os.path.join(args.out, "kelvin_sphere_slice.png")
fig.savefig(path, dpi=120)
err = np.abs(hr - exact).max()
print(f"max |h - closed form| along the ray: {err:.4f} (lx {args.lx}); {path}")
assert err < 0.05, "the field is far from the closed form"
