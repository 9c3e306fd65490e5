// The explorer's shapes: what the user edits (type, sizes, pose), the request body the server
// reads (the `distlab gap` SHAPE schema), and the three.js geometry that draws the same solid.
// Shapes live in their own frame with their axis along local z (as in distlab's geometry module).
import * as THREE from "three";
import { shapeGeometry as wireShapeGeometry, type ShapeJson } from "../../core/shapes";

export const SHAPE_TYPES = ["polytope", "box", "cylinder", "sphere", "capsule"] as const;
export type ShapeType = (typeof SHAPE_TYPES)[number];

export interface ShapeState {
  type: ShapeType;
  /** Box edge lengths (m). */
  size: [number, number, number];
  /** Radius of sphere, cylinder, capsule; circumradius of the polytope's pentagon. */
  radius: number;
  /** Cylinder and polytope height; capsule core-segment length. */
  height: number;
  position: [number, number, number];
  /** [w, x, y, z] as in the server's schema. */
  quaternion: [number, number, number, number];
}

/** Half-spaces A x ≤ b of a pentagonal prism: the paper's Fig. 1 pentagon, extruded along z. */
export function pentagonalPrism(radius: number, height: number): { A: Array<[number, number, number]>; b: number[] } {
  const A: Array<[number, number, number]> = [];
  const b: number[] = [];
  for (let i = 0; i < 5; i++) {
    const mid = Math.PI / 2 + (2 * Math.PI * (i + 0.5)) / 5;
    A.push([Math.cos(mid), Math.sin(mid), 0]);
    b.push(radius * Math.cos(Math.PI / 5)); // apothem
  }
  A.push([0, 0, 1], [0, 0, -1]);
  b.push(height / 2, height / 2);
  return { A, b };
}

/** The SHAPE object of the request, in the shape frame (no pose). */
export function shapeBody(s: ShapeState): ShapeJson {
  switch (s.type) {
    case "box":
      return { type: "box", size: [...s.size] };
    case "sphere":
      return { type: "sphere", radius: s.radius };
    case "cylinder":
      return { type: "cylinder", radius: s.radius, height: s.height };
    case "capsule":
      return { type: "capsule", radius: s.radius, height: s.height };
    case "polytope": {
      const { A, b } = pentagonalPrism(s.radius, s.height);
      return { type: "polytope", A, b };
    }
  }
}

/** The SHAPE object with its pose, as sent to /api/gap/distance. */
export function shapeRequest(s: ShapeState): ShapeJson {
  return { ...shapeBody(s), pose: { position: [...s.position], quaternion: [...s.quaternion] } };
}

/** A three.js geometry of the solid (the one builder, core/shapes, on the request's SHAPE). */
export function shapeGeometry(s: ShapeState): THREE.BufferGeometry {
  return wireShapeGeometry(shapeBody(s), "fine");
}

/** Radius of a ball around the shape's origin that contains it (for framing and plane sizes). */
export function boundingRadius(s: ShapeState): number {
  switch (s.type) {
    case "box":
      return Math.hypot(...s.size) / 2;
    case "sphere":
      return s.radius;
    case "cylinder":
    case "polytope":
      return Math.hypot(s.radius, s.height / 2);
    case "capsule":
      return s.radius + s.height / 2;
  }
}

export function poseOf(s: ShapeState): { position: THREE.Vector3; quaternion: THREE.Quaternion } {
  const [w, x, y, z] = s.quaternion;
  return { position: new THREE.Vector3(...s.position), quaternion: new THREE.Quaternion(x, y, z, w).normalize() };
}

export function setPose(s: ShapeState, o: THREE.Object3D): void {
  s.position = [o.position.x, o.position.y, o.position.z];
  const q = o.quaternion;
  s.quaternion = [q.w, q.x, q.y, q.z];
}
