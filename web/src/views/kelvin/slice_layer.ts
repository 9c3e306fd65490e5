// A slice plane through the object coloured by h, sampled with one batch query on a grid (within
// the server's max_query_points); NaN (grey) inside the object. Resampled after every σ change.
import * as THREE from "three";
import { api } from "../../core/api";
import { resolveRange, type ColorScale } from "../../core/colormap";
import { SlicePlane } from "../../core/slice";
import type { PostResponse } from "../../core/wire";
import { Coalescer } from "./coalesce";

export type SliceAxis = "x" | "y" | "z";
export const sliceAxes: readonly SliceAxis[] = ["x", "y", "z"];

/** POST /api/kelvin/objects/{id}/query's answer: h, ∇h and inside per point. */
export type QueryResult = PostResponse<"/api/kelvin/objects/{id}/query">;

export class SliceLayer {
  readonly plane = new SlicePlane();
  private resolution = 96;
  private objectId: string | null = null;
  private bounds = new THREE.Box3();
  private axis: SliceAxis = "z";
  private offset = 0; // fraction of the object's half-extent along the axis
  private coalescer: Coalescer<void>;
  lastSigmaVersion = -1;
  lastSampleMs = 0;
  onSampled: (() => void) | null = null;
  /** h's smallest and largest value on the plane, and the range its colours span. */
  dataRange: [number, number] | null = null;
  colorRange: [number, number] = [-1, 1];
  private scale: ColorScale = { map: "coolwarm", mode: "symmetric", min: -1, max: 1 };
  onError: ((e: unknown) => void) | null = null;

  constructor(maxQueryPoints: number) {
    this.resolution = Math.max(16, Math.min(96, Math.floor(Math.sqrt(maxQueryPoints))));
    this.plane.visible = false;
    this.coalescer = new Coalescer(() => this.sample());
  }

  setObject(id: string | null, bounds: THREE.Box3): void {
    this.objectId = id;
    this.bounds.copy(bounds);
    this.refresh();
  }

  configure(axis: SliceAxis, offset: number, visible: boolean): void {
    this.axis = axis;
    this.offset = offset;
    this.plane.visible = visible && this.objectId !== null && this.plane.material.uniforms.field.value !== null;
    this.wantVisible = visible;
    this.refresh();
  }
  private wantVisible = false;

  refresh(): void {
    if (this.objectId && this.wantVisible) this.coalescer.push();
  }

  settled(): Promise<void> {
    return this.coalescer.settled();
  }

  private geometry() {
    const c = this.bounds.getCenter(new THREE.Vector3());
    const size = this.bounds.getSize(new THREE.Vector3());
    const k = this.axis === "x" ? 0 : this.axis === "y" ? 1 : 2;
    c.setComponent(k, c.getComponent(k) + (this.offset * size.getComponent(k)) / 2);
    const u: [number, number, number] = k === 0 ? [0, 1, 0] : [1, 0, 0];
    const v: [number, number, number] = k === 2 ? [0, 1, 0] : [0, 0, 1];
    const extent = Math.max(size.x, size.y, size.z) * 3;
    return { center: c.toArray() as [number, number, number], u, v, size: [extent, extent] as [number, number] };
  }

  private async sample(): Promise<void> {
    const id = this.objectId;
    if (!id) return;
    const g = this.geometry();
    const n = this.resolution;
    const points: number[][] = [];
    for (let j = 0; j < n; j++)
      for (let i = 0; i < n; i++) {
        const a = ((i + 0.5) / n - 0.5) * g.size[0],
          b = ((j + 0.5) / n - 0.5) * g.size[1];
        points.push([0, 1, 2].map((c) => g.center[c] + a * g.u[c] + b * g.v[c]));
      }
    const t0 = performance.now();
    let r: QueryResult;
    try {
      r = await api.post<QueryResult>(`/api/kelvin/objects/${id}/query`, { points });
    } catch (e) {
      this.onError?.(e);
      return;
    }
    if (id !== this.objectId) return;
    const values = new Float32Array(n * n);
    let lo = Infinity,
      hi = -Infinity;
    r.h.forEach((h, i) => {
      values[i] = h === null ? NaN : h;
      if (h !== null) {
        lo = Math.min(lo, h);
        hi = Math.max(hi, h);
      }
    });
    // Texel centres sit at (i + 0.5) / n: the plane spans the full grid cells.
    this.plane.setSamples({ center: g.center, u: g.u, v: g.v, size: g.size, resolution: [n, n], values });
    this.dataRange = Number.isFinite(lo) ? [lo, hi] : null;
    if (this.dataRange) this.plane.setStyle({ spacing: niceStep((hi - lo) / 12) });
    this.restyle();
    this.plane.visible = this.wantVisible;
    this.lastSigmaVersion = r.sigma_version;
    this.lastSampleMs = performance.now() - t0;
    this.onSampled?.();
  }

  /** The colour map and range of h (re-colours without sampling again). */
  setColor(scale: ColorScale): void {
    const mapChanged = scale.map !== this.scale.map;
    this.scale = { ...scale };
    if (mapChanged) this.plane.setStyle({ map: scale.map });
    this.restyle();
  }

  private restyle(): void {
    this.colorRange = resolveRange(this.scale, ...(this.dataRange ?? [NaN, NaN]));
    this.plane.setStyle({ range: this.colorRange });
  }

  /** Whether the plane is shown (it is hidden until its first samples arrive). */
  get shown(): boolean {
    return this.plane.visible;
  }

  dispose(): void {
    this.coalescer.cancelPending();
    this.plane.dispose();
  }
}

function niceStep(x: number): number {
  if (!(x > 0)) return 0.1;
  const p = 10 ** Math.floor(Math.log10(x));
  const m = x / p;
  return (m < 1.5 ? 1 : m < 3.5 ? 2 : m < 7.5 ? 5 : 10) * p;
}
