// Forward kinematics from GET /api/cbf/robot (standard DH, as its "convention" states), used only
// to draw the robot at q0 before any rollout exists; frames carry the server's world poses.
import * as THREE from "three";
import type { CbfRobot, PoseJson } from "./types";

export function poseMatrix(p: PoseJson): THREE.Matrix4 {
  const [w, x, y, z] = p.quaternion ?? [1, 0, 0, 0];
  return new THREE.Matrix4().compose(new THREE.Vector3(...p.position), new THREE.Quaternion(x, y, z, w).normalize(), new THREE.Vector3(1, 1, 1));
}

/** Frames T_0 … T_dof: T_i = T_{i−1} · Rz(q_i) · Tz(d_i) · Rx(α_i) · Tx(a_i). */
export function linkFrames(robot: CbfRobot, q: number[]): THREE.Matrix4[] {
  const out = [new THREE.Matrix4()];
  const m = new THREE.Matrix4();
  robot.dh.forEach((row, i) => {
    const T = out[i].clone();
    T.multiply(m.makeRotationZ(q[i] ?? 0));
    T.multiply(m.makeTranslation(0, 0, row.d));
    T.multiply(m.makeRotationX(row.alpha));
    T.multiply(m.makeTranslation(row.a, 0, 0));
    out.push(T);
  });
  return out;
}

/** World poses of the robot's primitives at q, as [x, y, z, qw, qx, qy, qz] like the frames'. */
export function primitivePoses(robot: CbfRobot, q: number[]): number[][] {
  const frames = linkFrames(robot, q);
  const p = new THREE.Vector3(), r = new THREE.Quaternion(), s = new THREE.Vector3();
  return robot.primitives.map((prim) => {
    frames[prim.link].clone().multiply(poseMatrix(prim.pose)).decompose(p, r, s);
    return [p.x, p.y, p.z, r.w, r.x, r.y, r.z];
  });
}
