// three.js geometry for a GAP shape as the server describes it (box, sphere, cylinder, capsule,
// polytope A x ≤ b, convex_hull points). Round shapes have their axis along local z (core/solids).
import * as THREE from "three";
import { ConvexGeometry } from "three/addons/geometries/ConvexGeometry.js";
import { capsuleAlongZ, cylinderAlongZ } from "../../core/solids";
import type { ShapeJson } from "./types";

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

export function shapeGeometry(s: ShapeJson): THREE.BufferGeometry {
  switch (s.type) {
    case "box":
      return new THREE.BoxGeometry(...(s.size ?? [0.1, 0.1, 0.1]));
    case "sphere":
      return new THREE.SphereGeometry(s.radius ?? 0.05, 32, 16);
    case "cylinder":
      return cylinderAlongZ(s.radius, s.height, 40);
    case "capsule":
      return capsuleAlongZ(s.radius, s.height, 8, 32);
    case "polytope":
      return new ConvexGeometry(polytopeVertices(s.A ?? [], s.b ?? []));
    case "convex_hull":
      return new ConvexGeometry((s.points ?? []).map((p) => new THREE.Vector3(p[0], p[1], p[2])));
    default:
      return new THREE.BoxGeometry(0.02, 0.02, 0.02);
  }
}
