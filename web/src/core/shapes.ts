// The one three.js builder of GAP shapes, as the wire describes them (GapShape: box, sphere,
// cylinder, capsule, polytope A x ≤ b, convex_hull points), for the GAP explorer and the CBF
// scene. Round solids have their axis along local z as in distlab's geometry module (three's
// cylinder and capsule have theirs along y).
import * as THREE from "three";
import { ConvexGeometry } from "three/addons/geometries/ConvexGeometry.js";
import type { Schemas } from "./wire";

export type ShapeJson = Schemas["GapShape"];

/** Segments around round solids; "fine" for a single edited shape, "coarse" for robot scenes. */
export type Detail = "fine" | "coarse";
const SEGMENTS: Record<Detail, { radial: number; cap: number; sphere: [number, number] }> = {
  fine: { radial: 64, cap: 12, sphere: [48, 24] },
  coarse: { radial: 40, cap: 8, sphere: [32, 16] },
};

/** Vertices of {x : A x ≤ b} (bounded): feasible intersections of every three planes. */
export function polytopeVertices(A: number[][], b: number[]): THREE.Vector3[] {
  const out: THREE.Vector3[] = [];
  const n = A.length;
  const m = new THREE.Matrix3();
  for (let i = 0; i < n; i++)
    for (let j = i + 1; j < n; j++)
      for (let k = j + 1; k < n; k++) {
        m.set(A[i][0], A[i][1], A[i][2], A[j][0], A[j][1], A[j][2], A[k][0], A[k][1], A[k][2]);
        if (Math.abs(m.determinant()) < 1e-12) continue;
        const x = new THREE.Vector3(b[i], b[j], b[k]).applyMatrix3(m.invert());
        if (A.every((row, r) => row[0] * x.x + row[1] * x.y + row[2] * x.z <= b[r] + 1e-9)) out.push(x);
      }
  return out;
}

/** The solid in its own frame (the shape's pose is not applied). */
export function shapeGeometry(s: ShapeJson, detail: Detail = "coarse"): THREE.BufferGeometry {
  const seg = SEGMENTS[detail];
  switch (s.type) {
    case "box": {
      const [x, y, z] = s.size ?? [0.1, 0.1, 0.1];
      return new THREE.BoxGeometry(x, y, z);
    }
    case "sphere":
      return new THREE.SphereGeometry(s.radius ?? 0.05, ...seg.sphere);
    case "cylinder":
      return new THREE.CylinderGeometry(s.radius, s.radius, s.height, seg.radial).rotateX(Math.PI / 2);
    case "capsule":
      // height: the core segment's length (between the two hemispheres' centres)
      return new THREE.CapsuleGeometry(s.radius, s.height, seg.cap, seg.radial).rotateX(Math.PI / 2);
    case "polytope":
      return new ConvexGeometry(polytopeVertices(s.A ?? [], s.b ?? []));
    case "convex_hull":
      return new ConvexGeometry((s.points ?? []).map((p) => new THREE.Vector3(p[0], p[1], p[2])));
    default:
      return new THREE.BoxGeometry(0.02, 0.02, 0.02);
  }
}
