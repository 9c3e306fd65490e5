// A coarse stand-in for a large mesh, drawn while the camera is dragged where every triangle is
// costly (a software rasteriser: SwiftShader spends ~0.25 µs per triangle of the 200k-triangle
// sphere). meshoptimizer's simplifier keeps a subset of the vertices, so the stand-in is only a
// new index over the same vertex attributes: σ colours painted later show on both.
import * as THREE from "three";
import type { SimplifyAnswer, SimplifyRequest } from "./simplify.worker";

export interface StandIn {
  geometry: THREE.BufferGeometry;
  triangles: number;
  /** The simplifier's error bound, in the mesh's units. */
  error: number;
}

/** Relative error the simplifier may reach before the triangle target (1% of the mesh's extent). */
const MAX_RELATIVE_ERROR = 0.01;

/** A stand-in of at most `triangles` triangles for an indexed geometry that has more than twice
 *  as many; null for smaller or non-indexed geometries, or when the simplifier cannot run. */
export async function simplifiedStandIn(full: THREE.BufferGeometry, triangles: number): Promise<StandIn | null> {
  const index = full.getIndex();
  const position = full.getAttribute("position");
  if (!index || !(position instanceof THREE.BufferAttribute) || index.count / 3 <= 2 * triangles) return null;
  // Copies, handed over to the worker.
  const request: SimplifyRequest = {
    positions: new Float32Array(position.array as ArrayLike<number>),
    index: new Uint32Array(index.array as ArrayLike<number>),
    targetTriangles: triangles,
    targetError: MAX_RELATIVE_ERROR,
  };
  const answer = await new Promise<SimplifyAnswer | null>((resolve) => {
    const worker = new Worker(new URL("./simplify.worker.ts", import.meta.url), { type: "module" });
    const done = (a: SimplifyAnswer | null) => (worker.terminate(), resolve(a));
    worker.onmessage = (e: MessageEvent<SimplifyAnswer | null>) => done(e.data);
    worker.onerror = () => done(null);
    worker.postMessage(request, { transfer: [request.positions.buffer, request.index.buffer] });
  });
  if (!answer || answer.index.length === 0) return null;
  const geometry = new THREE.BufferGeometry();
  for (const [name, attribute] of Object.entries(full.attributes)) geometry.setAttribute(name, attribute);
  geometry.setIndex(new THREE.BufferAttribute(answer.index, 1));
  geometry.boundingBox = full.boundingBox?.clone() ?? null;
  geometry.boundingSphere = full.boundingSphere?.clone() ?? null;
  return { geometry, triangles: answer.index.length / 3, error: answer.relativeError * answer.scale };
}
