// Forward kinematics from GET /api/cbf/robot (its URDF joint tree, as its "convention" states),
// used only to draw the robot at q0 before any rollout exists; frames carry the server's world poses.
import * as THREE from "three";
import type { CbfRobot, PoseJson } from "./types";

/** A pose as the wire gives it (GapShape's pose: both parts optional, the identity by default). */
export function poseMatrix(p: { position?: number[]; quaternion?: number[] } | PoseJson): THREE.Matrix4 {
  const [w, x, y, z] = p.quaternion ?? [1, 0, 0, 0];
  const [px, py, pz] = p.position ?? [0, 0, 0];
  return new THREE.Matrix4().compose(new THREE.Vector3(px, py, pz), new THREE.Quaternion(x, y, z, w).normalize(), new THREE.Vector3(1, 1, 1));
}

/**
 * World frame of every link: child = parent · origin · Rot(axis, θ) (revolute) or Trans(axis θ)
 * (prismatic), θ = multiplier · q[joint.q] + offset (joints are listed parents first).
 */
export function linkFrames(robot: CbfRobot, q: number[]): THREE.Matrix4[] {
  const out = robot.links.map(() => new THREE.Matrix4());
  const m = new THREE.Matrix4();
  for (const j of robot.joints) {
    const T = out[j.parent].clone().multiply(poseMatrix(j.origin));
    if (j.q >= 0) {
      const theta = j.multiplier * (q[j.q] ?? 0) + j.offset;
      const axis = new THREE.Vector3(...j.axis).normalize();
      if (j.type === "prismatic") T.multiply(m.makeTranslation(axis.x * theta, axis.y * theta, axis.z * theta));
      else T.multiply(m.makeRotationAxis(axis, theta));
    }
    out[j.child] = T;
  }
  return out;
}

/** World poses of the robot's primitives at q, as [x, y, z, qw, qx, qy, qz] like the frames'. */
export function primitivePoses(robot: CbfRobot, q: number[]): number[][] {
  const frames = linkFrames(robot, q);
  const p = new THREE.Vector3(),
    r = new THREE.Quaternion(),
    s = new THREE.Vector3();
  return robot.primitives.map((prim) => {
    frames[prim.link].clone().multiply(poseMatrix(prim.pose)).decompose(p, r, s);
    return [p.x, p.y, p.z, r.w, r.x, r.y, r.z];
  });
}
