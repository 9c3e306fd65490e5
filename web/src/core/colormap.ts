// Colour maps for scalar quantities (σ on a surface, h and e_S on slice planes), one definition
// for the vertex colours, the slice shader's look-up texture and the colour bar: the maps are
// d3-scale-chromatic's, sampled into a 256-entry table. A diverging map is centred at 0 (the
// two halves of the range are stretched separately, so 0 is always the map's middle).
import { interpolateCividis, interpolateMagma, interpolatePuOr, interpolateRdBu, interpolateViridis } from "d3-scale-chromatic";
import { ticks } from "d3-array";
import * as THREE from "three";

export const colormapNames = ["viridis", "magma", "cividis", "coolwarm", "purple-orange"] as const;
export type ColormapName = (typeof colormapNames)[number];
export const rangeModes = ["auto", "symmetric", "fixed"] as const;
export type RangeMode = (typeof rangeModes)[number];

const maps: Record<ColormapName, { diverging: boolean; f: (t: number) => string }> = {
  viridis: { diverging: false, f: interpolateViridis },
  magma: { diverging: false, f: interpolateMagma },
  cividis: { diverging: false, f: interpolateCividis },
  coolwarm: { diverging: true, f: (t) => interpolateRdBu(1 - t) }, // blue (negative) to red
  "purple-orange": { diverging: true, f: (t) => interpolatePuOr(1 - t) },
};

/** How a quantity is coloured: the map, and the range (auto: the data's; symmetric: ±max|data|; fixed: min, max). */
export interface ColorScale {
  map: ColormapName;
  mode: RangeMode;
  min: number;
  max: number;
}

export function isDiverging(map: ColormapName): boolean {
  return maps[map].diverging;
}

const N = 256;
const tables = new Map<ColormapName, { srgb: Uint8Array; linear: Float32Array }>();
function table(map: ColormapName) {
  let t = tables.get(map);
  if (!t) {
    const srgb = new Uint8Array(N * 4),
      linear = new Float32Array(N * 3);
    const c = new THREE.Color();
    for (let i = 0; i < N; i++) {
      c.setStyle(maps[map].f(i / (N - 1)), THREE.SRGBColorSpace); // stored linear
      const s = c.clone().convertLinearToSRGB();
      srgb.set([Math.round(s.r * 255), Math.round(s.g * 255), Math.round(s.b * 255), 255], i * 4);
      linear.set([c.r, c.g, c.b], i * 3);
    }
    tables.set(map, (t = { srgb, linear }));
  }
  return t;
}

/** The map's 256 sRGB colours, RGBA bytes (the slice shader's texture, the colour bar's pixels). */
export function colormapBytes(map: ColormapName): Uint8Array {
  return table(map).srgb;
}

/** The range to colour: [lo, hi] with lo < hi, from the scale and the data's min and max. */
export function resolveRange(s: ColorScale, dataMin: number, dataMax: number): [number, number] {
  let lo: number, hi: number;
  if (s.mode === "fixed") [lo, hi] = [Math.min(s.min, s.max), Math.max(s.min, s.max)];
  else if (!Number.isFinite(dataMin) || !Number.isFinite(dataMax)) [lo, hi] = [0, 1];
  else if (s.mode === "symmetric") {
    const m = Math.max(Math.abs(dataMin), Math.abs(dataMax));
    [lo, hi] = [-m, m];
  } else [lo, hi] = [dataMin, dataMax];
  if (!(hi > lo)) {
    const d = Math.max(Math.abs(lo) * 1e-3, 1e-6);
    [lo, hi] = [lo - d, hi + d];
  }
  return [lo, hi];
}

/** Position in the map, [0, 1]. Centred (diverging maps) and 0 inside the range: 0 ↦ ½, each side linear. */
export function normalize(v: number, lo: number, hi: number, centred: boolean): number {
  let t: number;
  if (centred && lo < 0 && hi > 0) t = v < 0 ? 0.5 - (0.5 * v) / lo : 0.5 + (0.5 * v) / hi;
  else t = (v - lo) / (hi - lo);
  return Math.max(0, Math.min(1, t));
}

/** Tick values of a colour bar: nice numbers, and 0 itself where a centred map has it in the middle. */
export function colorbarTicks(lo: number, hi: number, centred: boolean): number[] {
  if (centred && lo < 0 && hi > 0) return [...new Set([...ticks(lo, 0, 3), 0, ...ticks(0, hi, 3)])];
  return ticks(lo, hi, 6);
}

/** A scalar per vertex to a "color" attribute (linear RGB, as three.js vertex colours are). */
export class VertexColorizer {
  private lo = 0;
  private hi = 1;
  private centred = false;
  private lut: Float32Array = table("viridis").linear;

  set(map: ColormapName, range: [number, number]): void {
    this.lut = table(map).linear;
    this.centred = isDiverging(map);
    [this.lo, this.hi] = range;
  }

  write(attr: THREE.BufferAttribute, values: ArrayLike<number>, indices?: Iterable<number>): void {
    const a = attr.array as Float32Array,
      lut = this.lut;
    const one = (v: number) => {
      const k = Math.round(normalize(values[v], this.lo, this.hi, this.centred) * (N - 1)) * 3;
      a[v * 3] = lut[k];
      a[v * 3 + 1] = lut[k + 1];
      a[v * 3 + 2] = lut[k + 2];
    };
    if (indices) for (const v of indices) one(v);
    else for (let v = 0; v < values.length; v++) one(v);
    attr.needsUpdate = true;
  }
}

/** The smallest and largest finite values (NaN, NaN when there are none). */
export function finiteRange(values: ArrayLike<number>): [number, number] {
  let lo = Infinity,
    hi = -Infinity;
  for (let i = 0; i < values.length; i++) {
    const v = values[i];
    if (v < lo) lo = v;
    if (v > hi) hi = v;
  }
  return lo <= hi ? [lo, hi] : [NaN, NaN];
}
