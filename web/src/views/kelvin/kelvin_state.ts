// The view's shareable state (the URL's s= JSON): object (an asset, or an upload named by its
// digest), the reshaping (repair and its options, simplify, components), l_x, σ (preset or base
// constant plus painted brushes), iso-levels, slice, brush settings, camera. Every read is typed
// and bounded.
import { readColorScale } from "../../core/colorbar";
import type { ColorScale } from "../../core/colormap";
import { num, numArray, str } from "../../core/urlstate";
import { packBrushes, presetNames, unpackBrushes, type Brush, type PresetName } from "./sigma";
import { sliceAxes, type SliceAxis } from "./slice_layer";

export const exportFormats = ["stl", "obj", "ply", "glb"] as const;
export type ExportFormat = (typeof exportFormats)[number];
/** The unit an uploaded file is in (the server scales it to metres), and the repair asked for. */
export const uploadUnits = ["m", "cm", "mm", "in"] as const;
export type UploadUnit = (typeof uploadUnits)[number];
export const repairs = ["none", "fix", "wrap"] as const;
export type Repair = (typeof repairs)[number];
export const componentChoices = ["all", "largest"] as const;
export type Components = (typeof componentChoices)[number];

/** An uploaded mesh as a link names it: the digest the server gives it (SHA-256 of the mesh as read,
 *  in metres: the same file in another unit is another mesh), the file's name and size, its unit. */
export interface UploadRef {
  digest: string;
  name: string;
  bytes: number;
  unit: UploadUnit;
}

/** How the surface is reshaped before preparing (the request's repair, repair_options, simplify,
 *  components): each option of the server, 0 meaning the server's default. */
export interface Reshape {
  repair: Repair;
  holeEdges: number; // fix: holes bounded by at most this many edges are filled
  alpha: number; // wrap: α in metres (0: diagonal / 20)
  offset: number; // wrap: offset in metres (0: α / 30)
  simplify: number; // faces to simplify to first (0: none)
  components: Components;
}

export interface KelvinState extends Reshape {
  object: string; // an asset name, or "upload" (the mesh `upload` names)
  upload?: UploadRef;
  lx: number;
  preset: PresetName;
  base: number;
  brushes: Brush[];
  /** A link too long for its brushes refers to the σ file holding them (sigma_file.ts). */
  sigmaFile?: { stamps: number; digest: string };
  levels: number[];
  showIso: boolean;
  opacity: number;
  slice: { show: boolean; axis: SliceAxis; offset: number };
  brush: { on: boolean; value: number; radius: number; falloff: number };
  /** Colours of σ on the surface and of h on the slice plane. */
  sigmaColor: ColorScale;
  sliceColor: ColorScale;
  format: ExportFormat;
  unit: UploadUnit;
  /** The camera as last placed (orbit target and position, metres). */
  camera?: { position: number[]; target: number[] };
}

/** A quick default l_x per built-in asset (seconds to prepare on a laptop, not the paper's). */
export const defaultLx: Record<string, number> = { cube: 0.1, sphere: 0.1, knife: 0.05, wrench: 0.005 };

/** Contact nowhere by default (the zero level set floats outside the surface); paint σ > 0. */
export const DEFAULT_BASE = -0.5;

export function defaults(object = "cube"): KelvinState {
  return {
    object,
    lx: defaultLx[object] ?? 0.1,
    preset: "none",
    base: DEFAULT_BASE,
    brushes: [],
    levels: [0, 0.25, 0.5],
    showIso: true,
    opacity: 0.28,
    slice: { show: false, axis: "z", offset: 0 },
    brush: { on: true, value: 1, radius: 0, falloff: 0 }, // radius 0: chosen from the object's size
    sigmaColor: { map: "coolwarm", mode: "symmetric", min: -1, max: 1 },
    sliceColor: { map: "coolwarm", mode: "symmetric", min: -1, max: 1 },
    format: "stl",
    unit: "m",
    repair: "none",
    holeEdges: 0,
    alpha: 0,
    offset: 0,
    simplify: 0,
    components: "all",
  };
}

export function parseLevels(v: unknown, fallback: number[]): number[] {
  const list =
    typeof v === "string"
      ? v
          .split(/[,\s]+/)
          .filter(Boolean)
          .map(Number)
      : v;
  if (!Array.isArray(list)) return fallback;
  const out = [...new Set(list.filter((x): x is number => typeof x === "number" && Number.isFinite(x)))].sort((a, b) => a - b);
  return out.length ? out.slice(0, 16) : fallback;
}

function readSigmaFileRef(v: unknown): KelvinState["sigmaFile"] {
  const o = (v && typeof v === "object" ? v : {}) as Record<string, unknown>;
  const stamps = num(o.stamps, 0, 0, 1e7);
  return stamps > 0 && typeof o.digest === "string" && /^[0-9a-f]{16}$/.test(o.digest) ? { stamps: Math.round(stamps), digest: o.digest } : undefined;
}

function readUploadRef(v: unknown): UploadRef | undefined {
  const o = (v && typeof v === "object" ? v : {}) as Record<string, unknown>;
  if (typeof o.digest !== "string" || !/^[0-9a-f]{64}$/.test(o.digest)) return undefined;
  const name = typeof o.name === "string" && o.name.length > 0 ? o.name.slice(0, 255) : "the uploaded file";
  return { digest: o.digest, name, bytes: Math.round(num(o.bytes, 0, 0, 1e12)), unit: str(o.unit, uploadUnits, "m") };
}

function readCamera(v: unknown): KelvinState["camera"] {
  const o = (v && typeof v === "object" ? v : {}) as Record<string, unknown>;
  const p = numArray(o.position, 3, []),
    t = numArray(o.target, 3, []);
  return p.length === 3 && t.length === 3 && p.some((x, k) => x !== t[k]) ? { position: p, target: t } : undefined;
}

export function readState(raw: Record<string, unknown>): KelvinState {
  const object = typeof raw.object === "string" && /^[A-Za-z0-9_-]{1,64}$/.test(raw.object) ? raw.object : "cube";
  const d = defaults(object);
  const slice = (raw.slice ?? {}) as Record<string, unknown>;
  const brush = (raw.brush ?? {}) as Record<string, unknown>;
  return {
    object,
    lx: num(raw.lx, d.lx, 1e-4, 10),
    preset: str(raw.preset, presetNames, "none"),
    base: num(raw.base, DEFAULT_BASE, -20, 20),
    brushes: unpackBrushes(raw.brushes),
    sigmaFile: readSigmaFileRef(raw.sigmaFile),
    levels: parseLevels(raw.levels, d.levels),
    showIso: raw.showIso !== false,
    opacity: num(raw.opacity, d.opacity, 0.02, 1),
    slice: { show: slice.show === true, axis: str(slice.axis, sliceAxes, "z"), offset: num(slice.offset, 0, -1, 1) },
    brush: {
      on: brush.on !== false,
      value: num(brush.value, 1, -20, 20),
      radius: num(brush.radius, 0, 0, 100),
      falloff: num(brush.falloff, 0, 0, 100),
    },
    // Older links: "sigmaScale" s was the fixed range ±s.
    sigmaColor: readColorScale(
      raw.sigmaColor,
      typeof raw.sigmaScale === "number" ? { ...d.sigmaColor, mode: "fixed", min: -num(raw.sigmaScale, 1, 1e-3, 100), max: num(raw.sigmaScale, 1, 1e-3, 100) } : d.sigmaColor,
    ),
    sliceColor: readColorScale(raw.sliceColor, d.sliceColor),
    format: str(raw.format, exportFormats, "stl"),
    unit: str(raw.unit, uploadUnits, "m"),
    repair: str(raw.repair, repairs, "none"),
    upload: object === "upload" ? readUploadRef(raw.upload) : undefined,
    holeEdges: Math.round(num(raw.holeEdges, 0, 0, 1e7)),
    alpha: num(raw.alpha, 0, 0, 1e6),
    offset: num(raw.offset, 0, 0, 1e6),
    simplify: Math.round(num(raw.simplify, 0, 0, 1e8)),
    components: str(raw.components, componentChoices, "all"),
    camera: readCamera(raw.camera),
  };
}

export function writeStateJson(s: KelvinState): Record<string, unknown> {
  const out: Record<string, unknown> = { object: s.object, lx: s.lx, levels: s.levels };
  if (s.object === "upload" && s.upload) out.upload = s.upload;
  if (s.preset !== "none") out.preset = s.preset;
  if (s.base !== DEFAULT_BASE) out.base = s.base;
  if (s.brushes.length) out.brushes = packBrushes(s.brushes);
  else if (s.sigmaFile) out.sigmaFile = s.sigmaFile;
  if (!s.showIso) out.showIso = false;
  if (s.opacity !== 0.28) out.opacity = s.opacity;
  if (s.slice.show || s.slice.offset !== 0 || s.slice.axis !== "z") out.slice = s.slice;
  out.brush = s.brush;
  const d = defaults();
  if (JSON.stringify(s.sigmaColor) !== JSON.stringify(d.sigmaColor)) out.sigmaColor = s.sigmaColor;
  if (JSON.stringify(s.sliceColor) !== JSON.stringify(d.sliceColor)) out.sliceColor = s.sliceColor;
  if (s.format !== "stl") out.format = s.format;
  if (s.unit !== "m") out.unit = s.unit;
  if (s.repair !== "none") out.repair = s.repair;
  if (s.holeEdges > 0) out.holeEdges = s.holeEdges;
  if (s.alpha > 0) out.alpha = s.alpha;
  if (s.offset > 0) out.offset = s.offset;
  if (s.simplify > 0) out.simplify = s.simplify;
  if (s.components !== "all") out.components = s.components;
  if (s.camera) out.camera = s.camera;
  return out;
}
