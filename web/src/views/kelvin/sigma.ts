// σ on the object's surface as the server's Sigma body (a sum of terms), evaluated locally with
// the same formulas as backend/kelvin/src/sigma.cpp so the surface colours follow a stroke at
// once, without waiting for the server. The wrench presets are the project's case files.
import caseA from "../../../../assets/wrench_case_a.json?raw";
import caseB from "../../../../assets/wrench_case_b.json?raw";
import caseC from "../../../../assets/wrench_case_c.json?raw";

export type Vec3 = [number, number, number];

/** Eq. 24: tanh((|e_lᵀ(x − origin)| − d0) / width) σ_nom. */
export interface AxisTerm {
  axis: Vec3;
  d0?: number;
  sigma_nom?: number;
  origin?: Vec3;
  width?: number;
}

/** value within radius of center, smoothstep to 0 over falloff beyond it. */
export interface Brush {
  center: Vec3;
  radius: number;
  value: number;
  falloff: number;
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

export function evaluateBrush(b: Brush, x: ArrayLike<number>, i = 0): number {
  const d = Math.hypot(x[i] - b.center[0], x[i + 1] - b.center[1], x[i + 2] - b.center[2]);
  if (d <= b.radius) return b.value;
  if (b.falloff <= 0 || d >= b.radius + b.falloff) return 0;
  const s = 1 - (d - b.radius) / b.falloff;
  return b.value * s * s * (3 - 2 * s);
}

/** σ at every point of `positions` (xyz triples). */
export function evaluateAll(sigma: SigmaBody, positions: ArrayLike<number>, out: Float32Array = new Float32Array(positions.length / 3)): Float32Array {
  const axes = axisList(sigma.axis);
  const c = sigma.constant ?? 0;
  for (let v = 0, i = 0; v < out.length; v++, i += 3) {
    let s = c;
    for (const a of axes) s += evaluateAxis(a, positions, i);
    out[v] = s;
  }
  for (const b of sigma.brushes ?? []) addBrush(b, positions, out);
  return out;
}

/** Adds one brush's term to `values`; returns the indices it touched. */
export function addBrush(b: Brush, positions: ArrayLike<number>, values: Float32Array): number[] {
  const touched: number[] = [];
  const reach = b.radius + b.falloff;
  const [cx, cy, cz] = b.center;
  for (let v = 0, i = 0; v < values.length; v++, i += 3) {
    const dx = positions[i] - cx,
      dy = positions[i + 1] - cy,
      dz = positions[i + 2] - cz;
    if (Math.abs(dx) > reach || Math.abs(dy) > reach || Math.abs(dz) > reach) continue;
    const w = evaluateBrush(b, positions, i);
    if (w !== 0) {
      values[v] += w;
      touched.push(v);
    }
  }
  return touched;
}

/** σ at one point (for the brush's "paint towards a value" stamps). */
export function evaluateAt(sigma: SigmaBody, p: Vec3): number {
  let s = sigma.constant ?? 0;
  for (const a of axisList(sigma.axis)) s += evaluateAxis(a, p);
  for (const b of sigma.brushes ?? []) s += evaluateBrush(b, p);
  return s;
}

/** The full body: preset terms (or a base constant) plus painted brushes. */
export function composeSigma(preset: PresetName, base: number, brushes: Brush[]): SigmaBody {
  const body: SigmaBody = preset === "none" ? { constant: base } : structuredClone(presets[preset].sigma);
  if (brushes.length) body.brushes = brushes;
  return body;
}

/** Brushes in the URL: [x, y, z, radius, value, falloff], 5 significant digits. */
export function packBrushes(list: Brush[]): number[][] {
  const r = (x: number) => Number(x.toPrecision(5));
  return list.map((b) => [...b.center.map(r), r(b.radius), r(b.value), r(b.falloff)]);
}
export function unpackBrushes(v: unknown): Brush[] {
  if (!Array.isArray(v)) return [];
  const out: Brush[] = [];
  for (const b of v) {
    if (!Array.isArray(b) || b.length !== 6 || !b.every((x) => typeof x === "number" && Number.isFinite(x))) continue;
    if (b[3] < 0 || b[5] < 0) continue;
    out.push({ center: [b[0], b[1], b[2]], radius: b[3], value: b[4], falloff: b[5] });
  }
  return out;
}
