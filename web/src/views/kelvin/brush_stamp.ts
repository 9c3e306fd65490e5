// How a brush stamp changes σ (the server's rule, backend/kelvin/src/sigma.cpp), and the stamp the
// brush drops when painting towards a value. A stamp "towards" v sets σ ← (1 − w) σ + w v with its
// weight w ∈ [0, 1]: at every point a convex combination of σ and v, so σ moves monotonically
// towards v and never passes it, however stamps overlap or are spaced, and it is v where w = 1 (a
// stroke leaves no gap). An added stamp of v − σ(centre), the rule before, passed v wherever σ
// under it differed from σ(centre): overlapping strokes then swung and grew past the server's range.
import type { Brush, Vec3 } from "./sigma";

export interface BrushSettings {
  value: number;
  radius: number;
  falloff: number;
}

/** 1 within the brush's radius, smoothstep to 0 over its falloff beyond it. */
export function brushWeight(b: Brush, x: ArrayLike<number>, i = 0): number {
  const d = Math.hypot(x[i] - b.center[0], x[i + 1] - b.center[1], x[i + 2] - b.center[2]);
  if (d <= b.radius) return 1;
  if (b.falloff <= 0 || d >= b.radius + b.falloff) return 0;
  const s = 1 - (d - b.radius) / b.falloff;
  return s * s * (3 - 2 * s);
}

/** σ after the brush where its weight is w, given σ there from the terms before it. */
function moved(b: Brush, sigma: number, w: number): number {
  return b.mode === "towards" ? (1 - w) * sigma + w * b.value : sigma + w * b.value;
}

/** σ at x after the brush, given σ there from the terms before it. */
export function applyBrush(b: Brush, sigma: number, x: ArrayLike<number>, i = 0): number {
  return moved(b, sigma, brushWeight(b, x, i));
}

/** Calls f(vertex, weight) for each vertex (xyz triples) the brush reaches. */
function forEachReached(b: Brush, positions: ArrayLike<number>, f: (v: number, w: number) => boolean | void): void {
  const reach = b.radius + b.falloff;
  const [cx, cy, cz] = b.center;
  for (let v = 0, i = 0; i < positions.length; v++, i += 3) {
    if (Math.abs(positions[i] - cx) > reach || Math.abs(positions[i + 1] - cy) > reach || Math.abs(positions[i + 2] - cz) > reach) continue;
    const w = brushWeight(b, positions, i);
    if (w !== 0 && f(v, w) === false) return;
  }
}

/** Applies one brush to σ at the vertices; returns the indices it touched. */
export function applyBrushTo(b: Brush, positions: ArrayLike<number>, values: Float32Array | Float64Array): number[] {
  const touched: number[] = [];
  forEachReached(b, positions, (v, w) => {
    values[v] = moved(b, values[v], w);
    touched.push(v);
  });
  return touched;
}

/** The stamp at `centre` painting towards the brush value, or null when it would change σ at no
 *  vertex of the surface (positions, σ there) by 1e-3 of the value while covering one: a
 *  retraced stroke adds no stamps. A stamp that covers no vertex is kept (a coarse mesh). */
export function stampTowards(s: BrushSettings, centre: Vec3, positions: ArrayLike<number>, sigma: ArrayLike<number>): Brush | null {
  const b: Brush = { center: centre, radius: s.radius, value: s.value, falloff: s.falloff, mode: "towards" };
  const tol = 1e-3 * Math.max(1, Math.abs(s.value));
  let covers = false,
    changes = false;
  forEachReached(b, positions, (v, w) => {
    if (w === 1) covers = true;
    changes = w * Math.abs(s.value - sigma[v]) > tol;
    return !changes;
  });
  return changes || !covers ? b : null;
}
