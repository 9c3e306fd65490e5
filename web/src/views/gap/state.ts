// The explorer's whole state (what a shared URL restores): both shapes, GAP parameters,
// iso-surface levels and slice, the sweep, and what the 3D view draws (the gradient arrows and
// their scale). Reads from the URL are typed and clamped so a hand-edited link cannot inject the
// wrong type; the server still validates every number.
import { readColorScale } from "../../core/colorbar";
import type { ColorScale } from "../../core/colormap";
import { num, numArray, str } from "../../core/urlstate";
import { SHAPE_TYPES, type ShapeState } from "./shapes";

export const SOLVERS = ["newton", "fixed_point"] as const;
export const FIELDS = ["weak", "strict"] as const;
export const SURFACES = ["strict", "weak", "both", "none"] as const;
export const AXES = ["x", "y", "z"] as const;
export const MOTIONS = ["translate", "rotate"] as const;
export type Axis = (typeof AXES)[number];

export interface GapParams {
  h: number;
  k: number;
  eps: number;
  sigma: number;
  /** σ follows ε as σ = √(1 − 2ε) (the paper's default); false: σ as set by the user. */
  coupled: boolean;
  solver: (typeof SOLVERS)[number];
}

/** The default σ of a given ε (eq. 6's pairing), or null where 1 − 2ε < 0. */
export function sigmaOfEps(eps: number): number | null {
  return 1 - 2 * eps >= 0 ? Math.sqrt(1 - 2 * eps) : null;
}

export interface IsoState {
  /** Which shape the iso-surfaces and the slice surround. */
  around: "a" | "b";
  surfaces: (typeof SURFACES)[number];
  weak: number[];
  strict: number[];
  slice: (typeof FIELDS)[number] | "none";
  /** Slice normal in the shape's frame, and offset of the plane from its origin along it. */
  normal: Axis;
  offset: number;
  /** Contour spacing on the slice (field units). */
  spacing: number;
  /** The slice's colour map and range. */
  color: ColorScale;
}

export interface SweepState {
  motion: (typeof MOTIONS)[number];
  axis: Axis;
  /** Half-range: metres (translate) or radians (rotate), centred on B's current pose. */
  range: number;
  samples: number;
}

/** What the 3D view draws besides the shapes (display toggles a link carries). */
export interface DisplayState {
  /** The gradient of D for both shapes: ∂D/∂p as a straight arrow at the shape's witness point,
   *  ∂D/∂θ as an axis with a curved arrow about the shape's origin (requests gradient: true). */
  gradient: boolean;
  /** Arrow metres per unit of gradient: per (m/m) for ∂D/∂p, per (m/rad) for ∂D/∂θ; 0: chosen
   *  from the gradient shown (gradient.ts, autoScale). */
  linearScale: number;
  angularScale: number;
}

export interface GapState {
  a: ShapeState;
  b: ShapeState;
  params: GapParams;
  iso: IsoState;
  sweep: SweepState;
  display: DisplayState;
}

export function defaultState(): GapState {
  return {
    a: { type: "polytope", size: [0.4, 0.4, 0.4], radius: 0.25, height: 0.3, position: [0, 0, 0], quaternion: [1, 0, 0, 0] },
    b: { type: "box", size: [0.3, 0.3, 0.3], radius: 0.15, height: 0.3, position: [0.55, 0.1, 0], quaternion: [1, 0, 0, 0] },
    params: { h: 0.1, k: 2, eps: 0.01, sigma: Math.sqrt(1 - 2 * 0.01), coupled: true, solver: "newton" },
    iso: {
      around: "a",
      surfaces: "strict",
      weak: [0.002, 0.008],
      strict: [0.002, 0.008],
      slice: "strict",
      normal: "z",
      offset: 0,
      spacing: 0.003,
      color: { map: "viridis", mode: "auto", min: 0, max: 0.01 },
    },
    sweep: { motion: "translate", axis: "y", range: 0.8, samples: 121 },
    display: { gradient: true, linearScale: 0, angularScale: 0 },
  };
}

function levels(v: unknown, fallback: number[]): number[] {
  if (!Array.isArray(v)) return fallback;
  const out = v.filter((x): x is number => typeof x === "number" && Number.isFinite(x) && x > 0).slice(0, 16);
  return out.length === v.length ? out : fallback;
}

function shape(v: unknown, d: ShapeState): ShapeState {
  const o = (v && typeof v === "object" ? v : {}) as Record<string, unknown>;
  return {
    type: str(o.type, SHAPE_TYPES, d.type),
    size: numArray(o.size, 3, d.size) as [number, number, number],
    radius: num(o.radius, d.radius),
    height: num(o.height, d.height),
    position: numArray(o.position, 3, d.position) as [number, number, number],
    quaternion: numArray(o.quaternion, 4, d.quaternion) as [number, number, number, number],
  };
}

function obj(v: unknown): Record<string, unknown> {
  return (v && typeof v === "object" && !Array.isArray(v) ? v : {}) as Record<string, unknown>;
}

/** State from the URL, defaults for whatever is missing or malformed. */
export function parseState(raw: Record<string, unknown>): GapState {
  const d = defaultState();
  const p = obj(raw.params);
  const iso = obj(raw.iso);
  const sw = obj(raw.sweep);
  const disp = obj(raw.display);
  const eps = num(p.eps, d.params.eps);
  const sigma = num(p.sigma, sigmaOfEps(eps) ?? d.params.sigma);
  return {
    a: shape(raw.a, d.a),
    b: shape(raw.b, d.b),
    params: {
      h: num(p.h, d.params.h),
      k: num(p.k, d.params.k),
      eps,
      sigma,
      // A link from before the coupling, or with σ set apart from ε, keeps its σ.
      coupled: p.coupled === undefined ? sigma === sigmaOfEps(eps) : p.coupled === true,
      solver: str(p.solver, SOLVERS, d.params.solver),
    },
    iso: {
      around: str(iso.around, ["a", "b"] as const, d.iso.around),
      surfaces: str(iso.surfaces, SURFACES, d.iso.surfaces),
      weak: levels(iso.weak, d.iso.weak),
      strict: levels(iso.strict, d.iso.strict),
      slice: str(iso.slice, [...FIELDS, "none"] as const, d.iso.slice),
      normal: str(iso.normal, AXES, d.iso.normal),
      offset: num(iso.offset, d.iso.offset, -10, 10),
      spacing: num(iso.spacing, d.iso.spacing, 0, 10),
      color: readColorScale(iso.color, d.iso.color),
    },
    sweep: {
      motion: str(sw.motion, MOTIONS, d.sweep.motion),
      axis: str(sw.axis, AXES, d.sweep.axis),
      range: num(sw.range, d.sweep.range, 1e-3, 10),
      samples: Math.round(num(sw.samples, d.sweep.samples, 5, 1000)),
    },
    display: {
      gradient: typeof disp.gradient === "boolean" ? disp.gradient : d.display.gradient,
      linearScale: num(disp.linearScale, d.display.linearScale, 0, 1e6),
      angularScale: num(disp.angularScale, d.display.angularScale, 0, 1e6),
    },
  };
}

/** The GAP params as the server reads them. */
export function paramsBody(p: GapParams, extra: Record<string, unknown> = {}): Record<string, unknown> {
  return { h: p.h, k: p.k, eps: p.eps, sigma: p.sigma, solver: p.solver, validate: true, ...extra };
}

/** Levels as text ("0.002, 0.008") and back; throws a readable message on a bad entry. */
export function formatLevels(v: number[]): string {
  return v.join(", ");
}
export function parseLevels(text: string, field: string): number[] {
  const parts = text.split(/[\s,;]+/).filter((t) => t.length > 0);
  const out = parts.map((t) => Number(t));
  const bad = parts.find((_, i) => !(Number.isFinite(out[i]) && out[i] > 0));
  if (bad !== undefined) throw new Error(`${field}: "${bad}" is not a positive number`);
  if (out.length > 16) throw new Error(`${field}: at most 16 levels`);
  return out;
}
