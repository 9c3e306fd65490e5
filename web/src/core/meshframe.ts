// MeshFrame (the server's msgpack mesh: float32 positions, uint32 indices, optional float32
// per-vertex scalars, all little-endian bytes) → three.js BufferGeometry.
import * as THREE from "three";

export interface MeshFrame {
  type?: string;
  n_vertices: number;
  n_faces: number;
  positions: Uint8Array;
  indices: Uint8Array;
  scalars?: Uint8Array;
  [key: string]: unknown;
}

export function isMeshFrame(x: unknown): x is MeshFrame {
  const f = x as MeshFrame;
  return !!f && typeof f.n_vertices === "number" && f.positions instanceof Uint8Array && f.indices instanceof Uint8Array;
}

/** A typed view of little-endian bytes (copies when unaligned). */
export function floats(bytes: Uint8Array): Float32Array {
  if (bytes.byteOffset % 4 === 0) return new Float32Array(bytes.buffer, bytes.byteOffset, bytes.byteLength / 4);
  return new Float32Array(bytes.slice().buffer);
}
export function uints(bytes: Uint8Array): Uint32Array {
  if (bytes.byteOffset % 4 === 0) return new Uint32Array(bytes.buffer, bytes.byteOffset, bytes.byteLength / 4);
  return new Uint32Array(bytes.slice().buffer);
}

export function toGeometry(frame: MeshFrame): THREE.BufferGeometry {
  const g = new THREE.BufferGeometry();
  const pos = floats(frame.positions);
  if (pos.length !== frame.n_vertices * 3) throw new Error("mesh frame: positions do not match n_vertices");
  g.setAttribute("position", new THREE.BufferAttribute(pos, 3));
  g.setIndex(new THREE.BufferAttribute(uints(frame.indices), 1));
  if (frame.scalars) g.setAttribute("scalar", new THREE.BufferAttribute(floats(frame.scalars), 1));
  g.computeVertexNormals();
  g.computeBoundingBox();
  g.computeBoundingSphere();
  return g;
}
