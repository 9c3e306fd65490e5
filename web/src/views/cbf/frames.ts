// The steps of one rollout, kept compactly as they stream in (typed arrays indexed by step, not
// thousands of small JSON objects): q, u, task error, true clearance, per-pair distance and
// witnesses, primitive poses, and with Kelvin fields h at every control point and the closest
// surface point per field. Steps may arrive twice (live batches and a replay) or out of order
// after a reconnect: each index is stored once; `contiguous` is the prefix without holes.
// The number of joints is the robot's (GET /api/cbf/robot: dof).
import type { CbfFieldStep, CbfFrame } from "./types";

class Grow<T extends Float64Array | Float32Array> {
  data: T;
  constructor(
    private readonly make: (n: number) => T,
    readonly stride: number,
  ) {
    this.data = make(0);
  }
  ensure(steps: number): void {
    const need = steps * this.stride;
    if (this.data.length >= need) return;
    const next = this.make(Math.max(need, this.data.length * 2, 64 * this.stride));
    next.fill(NaN);
    next.set(this.data);
    this.data = next;
  }
}

export class FrameStore {
  readonly q: Grow<Float64Array>;
  readonly u: Grow<Float64Array>;
  readonly taskError = new Grow((n) => new Float64Array(n), 1);
  readonly minDistance = new Grow((n) => new Float64Array(n), 1); // true clearance (NaN = none)
  readonly minD = new Grow((n) => new Float64Array(n), 1); // min over pairs of the controller's D
  readonly distance: Grow<Float64Array>;
  readonly witnessA: Grow<Float32Array>;
  readonly witnessB: Grow<Float32Array>;
  readonly poses: Grow<Float32Array>;
  readonly flags = new Grow((n) => new Float32Array(n), 1); // 0 ok, 1 relaxed, 2 held
  /** Kelvin fields, per step: h per (field, control point), field-major; per field the smallest h,
   *  the closest surface point (world), σ there, its distance, the control point it is closest to,
   *  and the distances to the allowed and forbidden faces (NaN: undefined or none). */
  readonly h: Grow<Float64Array>;
  readonly minH: Grow<Float64Array>;
  readonly closest: Grow<Float32Array>;
  readonly closestSigma: Grow<Float64Array>;
  readonly closestDistance: Grow<Float64Array>;
  readonly closestPoint: Grow<Float64Array>;
  readonly allowedDistance: Grow<Float64Array>;
  readonly forbiddenDistance: Grow<Float64Array>;
  private present = new Uint8Array(0);
  /** Steps [0, contiguous) are all here. */
  contiguous = 0;
  /** Highest index received + 1. */
  extent = 0;
  received = 0;
  hasPairs = false;
  hasPoses = false;
  /** The largest h over every step and control point received (the colour range of h). */
  hMax = -Infinity;

  constructor(
    readonly pairCount: number,
    readonly primitiveCount: number,
    readonly dt: number,
    readonly dof: number,
    readonly fieldCount = 0,
    readonly pointCount = 0,
  ) {
    const perField = (n: number) => new Float64Array(n);
    this.h = new Grow(perField, fieldCount * pointCount);
    this.minH = new Grow(perField, fieldCount);
    this.closest = new Grow((n) => new Float32Array(n), fieldCount * 3);
    this.closestSigma = new Grow(perField, fieldCount);
    this.closestDistance = new Grow(perField, fieldCount);
    this.closestPoint = new Grow(perField, fieldCount);
    this.allowedDistance = new Grow(perField, fieldCount);
    this.forbiddenDistance = new Grow(perField, fieldCount);
    this.q = new Grow((n) => new Float64Array(n), dof);
    this.u = new Grow((n) => new Float64Array(n), dof);
    this.distance = new Grow((n) => new Float64Array(n), pairCount);
    this.witnessA = new Grow((n) => new Float32Array(n), pairCount * 3);
    this.witnessB = new Grow((n) => new Float32Array(n), pairCount * 3);
    this.poses = new Grow((n) => new Float32Array(n), primitiveCount * 7);
  }

  /** Stores the frames; returns how many were new. */
  add(frames: CbfFrame[]): number {
    let added = 0;
    for (const f of frames) {
      const i = f.i;
      if (!Number.isInteger(i) || i < 0) continue;
      this.reserve(i + 1);
      if (this.present[i]) continue;
      this.present[i] = 1;
      added++;
      const n = this.dof;
      this.q.data.set(f.q.slice(0, n), i * n);
      this.u.data.set(f.u.slice(0, n), i * n);
      this.taskError.data[i] = f.task_error;
      this.minDistance.data[i] = f.min_distance ?? NaN;
      this.flags.data[i] = f.held ? 2 : f.relaxed ? 1 : 0;
      const P = this.pairCount;
      if (f.distance && f.distance.length === P) {
        this.hasPairs = true;
        let m = Infinity;
        for (let k = 0; k < P; k++) {
          const d = f.distance[k];
          this.distance.data[i * P + k] = d;
          if (d < m) m = d;
        }
        this.minD.data[i] = m;
        const wa = f.witness_a!,
          wb = f.witness_b!;
        for (let k = 0; k < P; k++) {
          this.witnessA.data.set(wa[k], (i * P + k) * 3);
          this.witnessB.data.set(wb[k], (i * P + k) * 3);
        }
      }
      if (f.poses && f.poses.length === this.primitiveCount) {
        this.hasPoses = true;
        const base = i * this.primitiveCount * 7;
        f.poses.forEach((p, k) => this.poses.data.set(p, base + k * 7));
      }
      if (f.kelvin && f.kelvin.length === this.fieldCount) this.addFields(i, f.kelvin);
      if (i + 1 > this.extent) this.extent = i + 1;
    }
    while (this.contiguous < this.extent && this.present[this.contiguous]) this.contiguous++;
    this.received += added;
    return added;
  }

  private addFields(i: number, kelvin: CbfFieldStep[]): void {
    const P = this.pointCount,
      F = this.fieldCount;
    const v = (x: number | null) => x ?? NaN;
    kelvin.forEach((k, f) => {
      let m = Infinity;
      for (let p = 0; p < P; p++) {
        const h = v(k.h[p] ?? null);
        this.h.data[(i * F + f) * P + p] = h;
        if (h < m) m = h;
        if (h > this.hMax) this.hMax = h;
      }
      this.minH.data[i * F + f] = Number.isFinite(m) ? m : NaN;
      this.closest.data.set(k.closest, (i * F + f) * 3);
      this.closestSigma.data[i * F + f] = k.closest_sigma;
      this.closestDistance.data[i * F + f] = v(k.distance);
      this.closestPoint.data[i * F + f] = k.closest_control_point;
      this.allowedDistance.data[i * F + f] = v(k.allowed_distance);
      this.forbiddenDistance.data[i * F + f] = v(k.forbidden_distance);
    });
  }

  /** Field f's values of a per-field series over [0, n). */
  fieldSeries(g: Grow<Float64Array>, f: number, n: number): Float64Array {
    const out = new Float64Array(n);
    for (let i = 0; i < n; i++) out[i] = g.data[i * this.fieldCount + f];
    return out;
  }

  has(i: number): boolean {
    return i >= 0 && i < this.present.length && this.present[i] === 1;
  }

  /** The first missing index in [0, upTo), or -1. */
  firstMissing(upTo: number): number {
    for (let i = this.contiguous; i < upTo; i++) if (!this.has(i)) return i;
    return -1;
  }

  private reserve(steps: number): void {
    if (this.present.length < steps) {
      const p = new Uint8Array(Math.max(steps, this.present.length * 2, 64));
      p.set(this.present);
      this.present = p;
    }
    for (const g of [this.q, this.u, this.taskError, this.minDistance, this.minD, this.distance, this.witnessA, this.witnessB, this.poses, this.flags]) g.ensure(steps);
    for (const g of [this.h, this.minH, this.closest, this.closestSigma, this.closestDistance, this.closestPoint, this.allowedDistance, this.forbiddenDistance]) g.ensure(steps);
  }

  /** Joint j's velocity over [0, n). */
  uSeries(j: number, n: number): Float64Array {
    const out = new Float64Array(n);
    for (let i = 0; i < n; i++) out[i] = this.u.data[i * this.dof + j];
    return out;
  }
  scalarSeries(g: Grow<Float64Array>, n: number): Float64Array {
    return g.data.slice(0, n);
  }
  /** Pair indices sorted by the controller's distance at step i (closest first). */
  closestPairs(i: number): number[] {
    const P = this.pairCount;
    const idx = Array.from({ length: P }, (_, k) => k);
    const d = this.distance.data;
    return idx.sort((a, b) => d[i * P + a] - d[i * P + b]);
  }
  /** The step's frame as plain numbers (test hooks). */
  frame(i: number): { i: number; t: number; q: number[]; u: number[]; task_error: number; min_distance: number | null } | null {
    if (!this.has(i)) return null;
    const md = this.minDistance.data[i];
    const n = this.dof;
    return {
      i,
      t: i * this.dt,
      q: Array.from(this.q.data.subarray(i * n, i * n + n)),
      u: Array.from(this.u.data.subarray(i * n, i * n + n)),
      task_error: this.taskError.data[i],
      min_distance: Number.isFinite(md) ? md : null,
    };
  }
}
