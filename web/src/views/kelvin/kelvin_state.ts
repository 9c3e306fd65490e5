// The view's shareable state (the URL's s= JSON): object, l_x, σ (preset or base constant plus
// painted brushes), iso-levels, slice, brush settings. Every read is typed and bounded.
import { readColorScale } from "../../core/colorbar";
import type { ColorScale } from "../../core/colormap";
import { num, str } from "../../core/urlstate";
import { packBrushes, presetNames, unpackBrushes, type Brush, type PresetName } from "./sigma";
import { sliceAxes, type SliceAxis } from "./slice_layer";

export const exportFormats = ["stl", "obj", "ply", "glb"] as const;
export type ExportFormat = (typeof exportFormats)[number];
/** The unit an uploaded file is in (the server scales it to metres), and the repair asked for. */
export const uploadUnits = ["m", "cm", "mm", "in"] as const;
export type UploadUnit = (typeof uploadUnits)[number];
export const repairs = ["none", "fix", "wrap"] as const;
export type Repair = (typeof repairs)[number];

export interface KelvinState {
  object: string; // an asset name, or "upload" (not restorable: uploads live in the session)
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
  repair: Repair;
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
  };
}

export function writeStateJson(s: KelvinState): Record<string, unknown> {
  const out: Record<string, unknown> = { object: s.object, lx: s.lx, levels: s.levels };
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
  return out;
}
