// σ on the object's surface as the server's Sigma body (a sum of terms), evaluated locally with
// the same formulas as backend/kelvin/src/sigma.cpp so the surface colours follow a stroke at
// once, without waiting for the server. The wrench presets are the project's case files.
import caseA from "../../../../assets/wrench_case_a.json?raw";
import caseB from "../../../../assets/wrench_case_b.json?raw";
import caseC from "../../../../assets/wrench_case_c.json?raw";
import { applyBrush, applyBrushTo } from "./brush_stamp";

export type Vec3 = [number, number, number];

/** Eq. 24: tanh((|e_lᵀ(x − origin)| − d0) / width) σ_nom. */
export interface AxisTerm {
  axis: Vec3;
  d0?: number;
  sigma_nom?: number;
  origin?: Vec3;
  width?: number;
}

/** Weight 1 within radius of center, smoothstep to 0 over falloff beyond it: added, the term
 *  value · weight; "towards", σ moves towards value by the weight (brush_stamp.ts). */
export interface Brush {
  center: Vec3;
  radius: number;
  value: number;
  falloff: number;
  mode?: "towards";
}

export interface SigmaBody {
  constant?: number;
  axis?: AxisTerm | AxisTerm[];
  brushes?: Brush[];
}

export type PresetName = "none" | "a" | "b" | "c";
export const presetNames: readonly PresetName[] = ["none", "a", "b", "c"];

export interface Preset {
  label: string;
  asset: string;
  sigma: SigmaBody;
}

function parseCase(text: string): Preset {
  const c = JSON.parse(text) as { comment: string; mesh: { asset: string }; sigma: SigmaBody };
  return { label: c.comment, asset: c.mesh.asset, sigma: c.sigma };
}

export const presets: Record<Exclude<PresetName, "none">, Preset> = {
  a: parseCase(caseA),
  b: parseCase(caseB),
  c: parseCase(caseC),
};

function axisList(a: SigmaBody["axis"]): AxisTerm[] {
  return a === undefined ? [] : Array.isArray(a) ? a : [a];
}

export function evaluateAxis(t: AxisTerm, x: ArrayLike<number>, i = 0): number {
  const [ax, ay, az] = t.axis;
  const n = Math.hypot(ax, ay, az) || 1;
  const o = t.origin ?? [0, 0, 0];
  const d = Math.abs((ax * (x[i] - o[0]) + ay * (x[i + 1] - o[1]) + az * (x[i + 2] - o[2])) / n);
  return Math.tanh((d - (t.d0 ?? 0)) / (t.width ?? 1)) * (t.sigma_nom ?? 1);
}

/** σ at every point of `positions` (xyz triples): the other terms, then the brushes in order. */
export function evaluateAll(sigma: SigmaBody, positions: ArrayLike<number>, out: Float32Array = new Float32Array(positions.length / 3)): Float32Array {
  const axes = axisList(sigma.axis);
  const c = sigma.constant ?? 0;
  for (let v = 0, i = 0; v < out.length; v++, i += 3) {
    let s = c;
    for (const a of axes) s += evaluateAxis(a, positions, i);
    out[v] = s;
  }
  for (const b of sigma.brushes ?? []) applyBrushTo(b, positions, out);
  return out;
}

/** σ at one point (the probe's reading). */
export function evaluateAt(sigma: SigmaBody, p: Vec3): number {
  let s = sigma.constant ?? 0;
  for (const a of axisList(sigma.axis)) s += evaluateAxis(a, p);
  for (const b of sigma.brushes ?? []) s = applyBrush(b, s, p);
  return s;
}

/** The full body: preset terms (or a base constant) plus painted brushes. */
export function composeSigma(preset: PresetName, base: number, brushes: Brush[]): SigmaBody {
  const body: SigmaBody = preset === "none" ? { constant: base } : structuredClone(presets[preset].sigma);
  if (brushes.length) body.brushes = brushes;
  return body;
}

const r5 = (x: number) => Number(x.toPrecision(5));
/** A brush as a link holds it (5 significant digits). The page paints with this brush, so that
 *  a link, the σ file and the page that made them describe one σ exactly. */
export function linkPrecision(b: Brush): Brush {
  return { ...b, center: [r5(b.center[0]), r5(b.center[1]), r5(b.center[2])], radius: r5(b.radius), value: r5(b.value), falloff: r5(b.falloff) };
}

/** Brushes in the URL: [x, y, z, radius, value, falloff] (linkPrecision), and a 7th element 1
 *  for a brush towards its value (links from before it hold added brushes). */
export function packBrushes(list: Brush[]): number[][] {
  return list.map((b) => [...b.center.map(r5), r5(b.radius), r5(b.value), r5(b.falloff), ...(b.mode === "towards" ? [1] : [])]);
}
export function unpackBrushes(v: unknown): Brush[] {
  if (!Array.isArray(v)) return [];
  const out: Brush[] = [];
  for (const b of v) {
    if (!Array.isArray(b) || (b.length !== 6 && !(b.length === 7 && b[6] === 1)) || !b.every((x) => typeof x === "number" && Number.isFinite(x))) continue;
    if (b[3] < 0 || b[5] < 0) continue;
    out.push({ center: [b[0], b[1], b[2]], radius: b[3], value: b[4], falloff: b[5], ...(b.length === 7 ? { mode: "towards" as const } : {}) });
  }
  return out;
}
