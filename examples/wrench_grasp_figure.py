"""The wrench grasp three ways (issue 33): the Panda with the Franka Hand brings its finger pads to
the handle of the paper's wrench under a Kelvin-field barrier h ≥ δ with the semantic σ (handle
+0.5: contact allowed, ends −0.5: kept a safety distance away), with σ = 0 (pure avoidance), and
with the wrench's convex hull as an ordinary Euclidean obstacle (no field).

Distances are measured the same way for the three runs, from the recorded q: forward kinematics
(distlab.robot) of the scenario's control points, and exact point-to-triangle distances (numpy) to
the wrench's STL faces, split as the record splits them (the handle: faces with σ > δ at every
corner; the ends: σ < 0 at every corner; σ the scenario's semantic σ). For the two field runs they
are checked against the record's own numbers (allowed_distance, forbidden_distance, distance; the
same to 1e-9 m). The hull run has no field, so its h is not defined; its pad–hull pair distance
(the Euclidean distance the QP constrains) is drawn beside the pads' distance to the handle.

Writes wrench_grasp_figure.png and wrench_grasp_figure.json (the table) to --out, and exits
non-zero unless (--no-check): the semantic run ends with the pads ≤ 2 mm from the handle, keeps
h ≥ δ at every control point and its distance to the ends ≥ the safety distance, and the σ = 0
run never brings a control point within 2 mm of the wrench.
Run: PYTHONPATH=build/python /usr/bin/python3 examples/wrench_grasp_figure.py [--duration 15] [--out DIR]
     [--temp-cache] [--no-check]
"""

import argparse
import json
import os
import struct
import sys
import tempfile
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import distlab  # noqa: E402
from distlab import cbf  # noqa: E402
from distlab.robot import Robot  # noqa: E402

RUNS = {  # label: rollout params (besides duration)
    "semantic σ": {},
    "σ = 0": {"fields": [{"sigma": {}}]},
    "convex hull": {"field_mode": "hull", "record_pairs": True},
}
COLORS = {"semantic σ": "tab:blue", "σ = 0": "tab:orange", "convex hull": "tab:green"}
REACH_MM = 2.0  # the "pads reach the handle": ≤ 2 mm at the end
RECORD_TOL = 1e-9  # metres: our distances against the record's


def read_stl(path):
    """Triangles (F, 3, 3) of a binary STL (float32 corners as float64, as the C++ loader reads them)."""
    with open(path, "rb") as f:
        data = f.read()
    n = struct.unpack_from("<I", data, 80)[0]
    if len(data) != 84 + 50 * n:
        raise ValueError(f"{path}: not a binary STL")
    rec = np.frombuffer(data, np.dtype([("normal", "<f4", 3), ("v", "<f4", (3, 3)), ("attr", "<u2")]), n, 84)
    return rec["v"].astype(np.float64)


def sigma_at(spec, x):
    """σ at object-frame points x (..., 3): the constant plus the axis terms of eq. 24,
    tanh((|a·(x − o)| − d0) / width) σ_nom (kelvin/sigma.cpp). Other terms are not needed here."""
    if set(spec) - {"constant", "axis"}:
        raise ValueError(f"sigma terms {sorted(set(spec) - {'constant', 'axis'})} are not implemented in this example")
    s = np.full(x.shape[:-1], float(spec.get("constant", 0.0)))
    axes = spec.get("axis", [])
    for a in [axes] if isinstance(axes, dict) else axes:
        axis = np.asarray(a.get("axis", [1, 0, 0]), float)
        axis /= np.linalg.norm(axis)
        o = np.asarray(a.get("origin", [0, 0, 0]), float)
        s += np.tanh((np.abs((x - o) @ axis) - a.get("d0", 0.0)) / a.get("width", 1.0)) * a.get("sigma_nom", 1.0)
    return s


def quat_rotate(q, v):
    """Rotates v (..., 3) by the unit quaternions q (..., 4) [w, x, y, z]."""
    w, u = q[..., :1], q[..., 1:]
    t = 2 * np.cross(u, v)
    return v + w * t + np.cross(u, t)


def closest_on_triangles(x, a, b, c):
    """Closest points on the triangles (a, b, c) to x, row by row (all (K, 3)): Ericson, Real-Time
    Collision Detection, 5.1.5, its branches as masks (the first that holds wins)."""
    ab, ac = b - a, c - a
    ap, bp, cp = x - a, x - b, x - c

    def dot(u, v):
        return np.einsum("ij,ij->i", u, v)

    d1, d2, d3, d4, d5, d6 = dot(ab, ap), dot(ac, ap), dot(ab, bp), dot(ac, bp), dot(ab, cp), dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        denom = va + vb + vc
        q = a + (vb / denom)[:, None] * ab + (vc / denom)[:, None] * ac  # inside the face
        cases = [((d1 <= 0) & (d2 <= 0), a),
                 ((d3 >= 0) & (d4 <= d3), b),
                 ((d6 >= 0) & (d5 <= d6), c),
                 ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + (d1 / (d1 - d3))[:, None] * ab),
                 ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + (d2 / (d2 - d6))[:, None] * ac),
                 ((va <= 0) & (d4 >= d3) & (d5 >= d6), b + ((d4 - d3) / ((d4 - d3) + (d5 - d6)))[:, None] * (c - b))]
    for mask, point in reversed(cases):
        q = np.where(mask[:, None], point, q)
    return q


def surface_distance(points, tri, chunk=8192):
    """Exact distance of every point (N, 3) to the triangles (F, 3, 3) (+inf without triangles).
    Faces are culled by bounding spheres: a face whose sphere is farther than the exact distance to
    the face of the nearest sphere cannot be the closest."""
    if len(tri) == 0:
        return np.full(len(points), np.inf)
    centre = tri.mean(1)
    radius = np.linalg.norm(tri - centre[:, None], axis=2).max(1)
    c2 = (centre ** 2).sum(1)
    out = np.empty(len(points))
    for s in range(0, len(points), chunk):
        x = points[s:s + chunk]
        lower = np.sqrt(np.maximum((x ** 2).sum(1)[:, None] + c2 - 2 * x @ centre.T, 0)) - radius
        f0 = lower.argmin(1)
        upper = np.linalg.norm(x - closest_on_triangles(x, tri[f0, 0], tri[f0, 1], tri[f0, 2]), axis=1)
        i, f = np.nonzero(lower <= upper[:, None] + 1e-12)
        d = np.linalg.norm(x[i] - closest_on_triangles(x[i], tri[f, 0], tri[f, 1], tri[f, 2]), axis=1)
        np.minimum.at(upper, i, d)
        out[s:s + chunk] = upper
    return out


def control_points_world(robot, q, points):
    """World positions (S, C, 3) of the control points (link index into robot.links, link-frame point)."""
    T = robot.fk(q)  # (S, L, 7)
    out = []
    for c in points:
        local = np.broadcast_to(np.asarray(c["point"], float), T[:, 0, :3].shape)
        out.append(T[:, c["link"], :3] + quat_rotate(T[:, c["link"], 3:], local))
    return np.stack(out, axis=1)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the scenario's, 15)")
    ap.add_argument("--out", default=".", help="folder for the figure and the table")
    ap.add_argument("--temp-cache", action="store_true",
                    help="prepare the wrench's field in a temporary XDG_CACHE_HOME, removed at the end "
                         "(else the user's cache)")
    ap.add_argument("--no-check", action="store_true", help="draw only; do not fail on the outcomes")
    args = ap.parse_args()

    tmp = tempfile.TemporaryDirectory(prefix="distlab-cache-") if args.temp_cache else None
    if tmp is not None:
        os.environ["XDG_CACHE_HOME"] = tmp.name  # read by the C++ core at each preparation

    assets = os.environ.get("DISTLAB_ASSETS", distlab.assets_dir)
    with open(os.path.join(assets, "scenarios", "wrench_grasp.json")) as f:
        sc = json.load(f)
    field = sc["fields"][0]
    robot = Robot.load(sc["robot"])
    delta = field.get("delta", 0.0)

    # The wrench's faces in its object frame, split by the semantic σ at their corners (the record's split).
    tri = read_stl(os.path.join(assets, field["mesh"]["asset"] + ".stl"))
    sigma = sigma_at(field["sigma"], tri)  # (F, 3)
    handle, ends = sigma.min(1) > delta, sigma.max(1) < 0
    rest = ~(handle | ends)
    pose = field.get("pose", {})
    p_obj = np.asarray(pose.get("position", [0, 0, 0]), float)
    q_obj = np.asarray(pose.get("quaternion", [1, 0, 0, 0]), float)
    q_inv = q_obj * [1, -1, -1, -1]
    print(f"wrench: {len(tri)} faces, {handle.sum()} handle (σ > δ = {delta}), {ends.sum()} ends (σ < 0), "
          f"{rest.sum()} between")

    params = {} if args.duration is None else {"duration": args.duration}
    records, seconds = {}, {}
    for label, extra in RUNS.items():
        t0 = time.perf_counter()
        records[label] = cbf.rollout("wrench_grasp", "euclidean", {**params, **extra})
        seconds[label] = time.perf_counter() - t0
        print(f"{label}: {records[label]['steps']} steps in {seconds[label]:.1f} s")
    sem = records["semantic σ"]["kelvin"]
    points = sem["control_points"]
    pads = np.array(["pad" in c["name"] for c in points])  # the pads' face grids and points sampled on the pads
    safety = sem["fields"][0]["safety_distance"]

    failures, rows, series = [], [], {}
    for label, rec in records.items():
        x = control_points_world(robot, rec["q"], points) - p_obj
        x = quat_rotate(np.broadcast_to(q_inv, x.shape[:-1] + (4,)), x).reshape(-1, 3)  # object frame
        shape = (len(rec["t"]), len(points))
        d_handle = surface_distance(x, tri[handle]).reshape(shape)
        d_ends = surface_distance(x, tri[ends]).reshape(shape)
        d_all = np.minimum(np.minimum(d_handle, d_ends), surface_distance(x, tri[rest]).reshape(shape))
        s = {"t": rec["t"], "pads_handle": d_handle[:, pads].min(1), "ends": d_ends.min(1), "surface": d_all.min(1)}
        row = {"run": label, "final_distance_to_handle_mm": 1e3 * s["pads_handle"][-1],
               "min_distance_to_ends_mm": 1e3 * s["ends"].min(), "min_distance_to_wrench_mm": 1e3 * s["surface"].min(),
               "min_h": None, "reached": bool(rec["summary"]["reached"]),
               "infeasible_steps": len(rec["infeasible_steps"]),
               "final_task_error_mm": 1e3 * rec["summary"]["final_task_error"], "rollout_s": seconds[label]}
        if "kelvin" in rec:
            f = rec["kelvin"]["fields"][0]
            if "failure" in rec["kelvin"]:
                failures.append(f"{label}: the rollout stopped: {rec['kelvin']['failure']}")
            s["min_h"] = np.min(f["h"], axis=1)  # NaN (h undefined) propagates
            row["min_h"] = float(np.min(f["h"]))
            # Our distances are the record's (min over every control point; NaN where σ has no such faces).
            checks = [("distance", s["surface"])]
            if label == "semantic σ":
                checks += [("allowed_distance", d_handle.min(1)), ("forbidden_distance", s["ends"])]
            for key, ours in checks:
                err = np.max(np.abs(ours - f[key]))
                if not err <= RECORD_TOL:
                    failures.append(f"{label}: our {key} differs from the record's by {err:.3g} m")
        else:
            # The pair distances the QP constrained: pad boxes to the hull (Euclidean, FCL).
            cols = [i for i, n in enumerate(rec["pairs"]) if n.endswith("_pad/wrench")]
            s["pads_hull"] = rec["distance"][:, cols].min(1)
            row["final_pad_hull_distance_mm"] = 1e3 * s["pads_hull"][-1]
        series[label], rows = s, rows + [row]

    # The outcomes (issue 33, "Outcomes the run must show").
    r_sem, r_zero = rows[0], rows[1]
    if not r_sem["final_distance_to_handle_mm"] <= REACH_MM:
        failures.append(f"semantic σ: the pads end {r_sem['final_distance_to_handle_mm']:.3f} mm from the handle "
                        f"(> {REACH_MM} mm)")
    for r in rows[:2]:
        if not r["min_h"] >= delta:
            failures.append(f"{r['run']}: min h = {r['min_h']:.4f} < δ = {delta} at some control point and step")
    if safety is None:
        failures.append("semantic σ: the record has no safety distance (no forbidden faces?)")
    elif not r_sem["min_distance_to_ends_mm"] >= 1e3 * safety:
        failures.append(f"semantic σ: the control points came {r_sem['min_distance_to_ends_mm']:.3f} mm from the "
                        f"ends, the safety distance is {1e3 * safety:.3f} mm")
    if not r_zero["min_distance_to_wrench_mm"] >= REACH_MM:
        failures.append(f"σ = 0: a control point came {r_zero['min_distance_to_wrench_mm']:.3f} mm from the wrench "
                        f"(< {REACH_MM} mm)")

    # The figure.
    fig, ax = plt.subplots(3, 1, figsize=(8, 10), sharex=True)
    for label, s in series.items():
        ax[0].plot(s["t"], 1e3 * s["pads_handle"], color=COLORS[label], label=label)
        if "pads_hull" in s:
            ax[0].plot(s["t"], 1e3 * s["pads_hull"], color=COLORS[label], ls="--", lw=1,
                       label=f"{label}: pad boxes to the hull (the QP's pair distance)")
        ax[1].plot(s["t"], 1e3 * s["ends"], color=COLORS[label], label=label)
        if "min_h" in s:
            ax[2].plot(s["t"], s["min_h"], color=COLORS[label], label=label)
    ax[0].axhline(REACH_MM, color="gray", ls=":", lw=1, label=f"{REACH_MM:g} mm (reached)")
    ax[0].set_title("(a) finger pads' control points to the handle (faces with σ > δ)")
    ax[0].set_ylabel("distance (mm)")
    ax[0].set_yscale("log")
    if safety is not None:
        ax[1].axhline(1e3 * safety, color="red", ls="--", lw=1, label=f"safety distance {1e3 * safety:.2f} mm")
    ax[1].set_title("(b) every control point to the forbidden ends (faces with σ < 0)")
    ax[1].set_ylabel("distance (mm)")
    ax[1].set_yscale("log")
    ax[2].axhline(delta, color="red", ls="--", lw=1, label=f"δ = {delta:g}")
    ax[2].set_title("(c) min h over the control points (each run's own σ; the hull run has no field)")
    ax[2].set_ylabel("h (dimensionless)")
    ax[2].set_xlabel("t (s)")
    for a in ax:
        a.grid(alpha=0.3)
        a.legend(fontsize=7)
    fig.suptitle("wrench_grasp: Panda + Franka Hand, Euclidean pair rows")
    fig.tight_layout()
    os.makedirs(args.out, exist_ok=True)
    png = os.path.join(args.out, "wrench_grasp_figure.png")
    fig.savefig(png, dpi=120)

    # The table.
    columns = ("final d(handle) mm", 18), ("min d(ends) mm", 15), ("min h", 7), ("reached", 8), ("infeasible", 10)
    print(f"{'run':<12}" + "".join(f" {name:>{width}}" for name, width in columns))
    for r in rows:
        h = "—" if r["min_h"] is None else f"{r['min_h']:.4f}"
        print(f"{r['run']:<12} {r['final_distance_to_handle_mm']:>18.3f} {r['min_distance_to_ends_mm']:>15.3f} {h:>7} "
              f"{str(r['reached']):>8} {r['infeasible_steps']:>10}")
    table = {"scenario": "wrench_grasp", "metric": "euclidean",
             "duration": float(records["semantic σ"]["t"][-1] + sc["dt"]),
             "delta": delta, "safety_distance_mm": None if safety is None else 1e3 * safety, "reach_mm": REACH_MM,
             "notes": ["distances from the recorded q: FK of the control points, exact distances to the STL faces "
                       "(handle: σ > δ at every corner, ends: σ < 0, of the semantic σ); final_distance_to_handle: "
                       "the pads' control points (names with 'pad'); min_distance_to_ends, min_distance_to_wrench: "
                       "every control point, every step",
                       "min_h: over every control point and step, each run's own σ (none for the hull run)",
                       "rollout_s: wall time of the cbf.rollout call; the first one's includes preparing the field "
                       "unless it was cached"],
             "runs": rows, "failures": failures}
    path = os.path.join(args.out, "wrench_grasp_figure.json")
    with open(path, "w") as f:
        json.dump(table, f, indent=2, ensure_ascii=False)
    print(png)
    print(path)
    if tmp is not None:
        tmp.cleanup()
    for message in failures:
        print("FAILED:", message, file=sys.stderr)
    if failures and not args.no_check:
        sys.exit(1)


if __name__ == "__main__":
    main()
