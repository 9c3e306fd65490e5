// meshoptimizer's simplifier, off the page's thread: a 200k-triangle surface takes 0.25-0.35 s
// on this 2-core VM, which on the main thread would freeze the view while an object loads.
import { MeshoptSimplifier } from "meshoptimizer/simplifier";

export interface SimplifyRequest {
  positions: Float32Array; // xyz per vertex
  index: Uint32Array; // triangles
  targetTriangles: number;
  targetError: number; // relative to the mesh's extent
}
export interface SimplifyAnswer {
  index: Uint32Array; // into the same vertices
  relativeError: number;
  scale: number; // the mesh's extent: absolute error = relativeError · scale
}

self.onmessage = async (e: MessageEvent<SimplifyRequest>) => {
  try {
    await MeshoptSimplifier.ready;
    const { positions, index, targetTriangles, targetError } = e.data;
    // LockBorder: the display mesh is split along creases; both sides keep their border vertices,
    // so the stand-in has no cracks there.
    const [out, relativeError] = MeshoptSimplifier.simplify(index, positions, 3, 3 * targetTriangles, targetError, ["LockBorder"]);
    const answer: SimplifyAnswer = { index: out, relativeError, scale: MeshoptSimplifier.getScale(positions, 3) };
    self.postMessage(answer, { transfer: [out.buffer] });
  } catch {
    self.postMessage(null); // an async failure fires no error event: the page would wait forever
  }
};
