"""Your own CBF-QP loop on top of distlab.robot: the corridor controller of the paper (Section IV-B,
eq. 7) written in numpy, with Robot.cbf_rows giving the safety rows A u >= b and scipy's NNLS
solving the QP, reproduces the built-in corridor rollout's final task error.
Run: PYTHONPATH=build/python /usr/bin/python3 examples/robot_cbf_loop.py [--duration 35] [--metric gap]
"""

import argparse
import json
import os
import time

import numpy as np
from scipy.optimize import nnls

import distlab
from distlab import cbf
from distlab.robot import Robot


def quat_to_R(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def skew(a):
    return np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])


def qp(H, f, A, b):
    """min ½uᵀHu + fᵀu s.t. A u >= b, exactly, as a least distance problem solved by NNLS
    (Lawson & Hanson, "Solving Least Squares Problems", ch. 23): with H = L Lᵀ and z = Lᵀu + L⁻¹f,
    minimise |z| s.t. (A L⁻ᵀ) z >= b + A H⁻¹ f. None if the rows are infeasible."""
    L = np.linalg.cholesky(H)
    G = np.linalg.solve(L, A.T).T  # A L⁻ᵀ
    u0 = -np.linalg.solve(H, f)  # the unconstrained minimum
    h = b - A @ u0
    y, _ = nnls(np.vstack([G.T, h]), np.r_[np.zeros(len(f)), 1.0], maxiter=50 * len(b))
    r = np.vstack([G.T, h]) @ y - np.r_[np.zeros(len(f)), 1.0]
    if np.linalg.norm(r) < 1e-12:
        return None
    z = -r[:-1] / r[-1]
    return u0 + np.linalg.solve(L.T, z)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--duration", type=float, default=None, help="simulated seconds (default: the scenario's)")
    ap.add_argument("--metric", default="gap", choices=["gap", "euclidean"])
    args = ap.parse_args()

    # The corridor scenario, as data: the robot, the obstacles (GAP shapes), the controller's constants.
    with open(os.path.join(distlab.assets_dir, "scenarios", "corridor.json")) as f:
        sc = json.load(f)
    robot = Robot.load(sc["robot"])
    obstacles = [dict(o["shape"], name=o["name"]) for o in sc["obstacles"]]
    params = {k: v for k, v in sc["gap"].items() if k != "mode"}
    p_d, R_d = np.array(sc["target"]["position"]), quat_to_R(sc["target"]["quaternion"])
    dt = sc["dt"]
    steps = round((sc["duration"] if args.duration is None else args.duration) / dt)
    ee = robot.links.index(robot.ee_link)

    def task(q):
        """r(q) = [p − p_d; max(0, 1 − a_d,i · a_i)] (a_i the end effector's axes) and J_r."""
        pose, J = robot.fk(q)[ee], robot.jacobian(q)
        R = quat_to_R(pose[3:])
        r = np.r_[pose[:3] - p_d, np.maximum(0, 1 - np.sum(R_d * R, axis=0))]
        return r, np.vstack([J[:3]] + [R_d[:, i] @ skew(R[:, i]) @ J[3:] for i in range(3)])

    # The loop: min ½|J_r u + K r|² + ½λ|u|² subject to the CBF rows, then q += u dt.
    q, state, t0 = np.array(sc["q0"], dtype=float), None, time.perf_counter()
    for step in range(steps):
        r, Jr = task(q)
        H, f = Jr.T @ Jr + sc["damping"] * np.eye(robot.dof), Jr.T @ (sc["task_gain"] * r)
        rows = robot.cbf_rows(q, obstacles, args.metric, "both", sc["margins"][args.metric], sc["eta"],
                              sc["eta_joint"], params, warm_start=state)
        state, (A, b) = rows.state, rows
        u = qp(H, f, A, b)
        if u is None:  # the built-in controller would relax the distance rows by a slack here
            raise RuntimeError(f"the CBF rows are infeasible at step {step}")
        q = q + u * dt
    ours = np.linalg.norm(task(q)[0])
    seconds = time.perf_counter() - t0

    rec = cbf.rollout("corridor", args.metric, {"duration": steps * dt})
    theirs = rec["summary"]["final_task_error"]
    print(f"{steps} steps in {seconds:.2f} s ({1e3 * seconds / steps:.2f} ms per step); "
          f"the built-in rollout relaxed {len(rec['infeasible_steps'])} steps")
    print(f"final task error: this loop {ours:.12g}, built-in rollout {theirs:.12g}, "
          f"difference {abs(ours - theirs):.3g}; final q differs by {np.abs(q - rec['summary']['q_final']).max():.3g}")
    assert abs(ours - theirs) <= 1e-8 * theirs, "the loop does not reproduce the rollout"


if __name__ == "__main__":
    main()
