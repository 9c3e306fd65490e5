// The sweep: D along a straight motion of shape B (a translation along an axis, or a rotation
// about an axis through B's origin), centred on B's current pose, GAP beside Euclidean. One batch
// POST of all poses with gradients; the derivative along the motion is gradient_b · direction
// (linear part for a translation, angular part for a rotation: gradients are per unit linear and
// angular velocity, world frame, about the shape's origin). The Euclidean derivative jumps or
// kinks where its witness points switch; GAP's stays smooth.
import * as THREE from "three";
import { api, ApiError, errorText } from "../../core/api";
import { LatestWins, type LatestResult } from "../../core/latest";
import { Plot } from "../../core/plot";
import type { GapResult } from "./readout";
import { shapeRequest, type ShapeState } from "./shapes";
import { paramsBody, type GapParams, type SweepState } from "./state";

export interface SweepInput {
  a: ShapeState;
  b: ShapeState;
  params: GapParams;
  sweep: SweepState;
}

export interface SweepData {
  s: number[];
  gap: number[];
  euclid: number[];
  dGap: number[];
  dEuclid: number[];
}

const AXIS = { x: new THREE.Vector3(1, 0, 0), y: new THREE.Vector3(0, 1, 0), z: new THREE.Vector3(0, 0, 1) };

/** B's poses along the motion; s is metres (translate) or radians (rotate). */
export function sweepPoses(b: ShapeState, sw: SweepState): Array<{ s: number; shape: ShapeState }> {
  const dir = AXIS[sw.axis];
  const [w, x, y, z] = b.quaternion;
  const q0 = new THREE.Quaternion(x, y, z, w).normalize();
  const out: Array<{ s: number; shape: ShapeState }> = [];
  for (let i = 0; i < sw.samples; i++) {
    const s = -sw.range + (2 * sw.range * i) / (sw.samples - 1);
    const shape = structuredClone(b);
    if (sw.motion === "translate") {
      shape.position = [b.position[0] + s * dir.x, b.position[1] + s * dir.y, b.position[2] + s * dir.z];
    } else {
      const q = new THREE.Quaternion().setFromAxisAngle(dir, s).multiply(q0); // world-frame rotation
      shape.quaternion = [q.w, q.x, q.y, q.z];
    }
    out.push({ s, shape });
  }
  return out;
}

function along(g: number[] | undefined, sw: SweepState): number {
  if (!g) return NaN;
  const d = AXIS[sw.axis];
  const o = sw.motion === "translate" ? 0 : 3;
  return g[o] * d.x + g[o + 1] * d.y + g[o + 2] * d.z;
}

export class Sweep {
  readonly dPlot: Plot;
  readonly derivPlot: Plot;
  private readonly requests: LatestWins<SweepInput, SweepData>;
  last: SweepData | null = null;

  constructor(
    container: HTMLElement,
    private readonly onDone: (error: unknown | null) => void,
  ) {
    // D and d are both lengths (D = √(2Λ) ≤ d for separated shapes): one axis, so they compare.
    this.dPlot = new Plot(container, {
      title: "D along the motion of B",
      caption: "GAP D = √(2Λ) (orange) and the Euclidean signed distance d (green, below 0 the penetration depth) against the motion s of B.",
      xLabel: "s (m)",
      yLabel: "distance (m)",
      series: [
        { label: "GAP D", color: "#ffb347", width: 2 },
        { label: "Euclidean d", color: "#6ad1a3", width: 2 },
      ],
    });
    this.derivPlot = new Plot(container, {
      title: "dD/ds",
      caption: "The derivatives along the motion: GAP dD/ds (orange, smooth) and Euclidean dd/ds (green, jumps where its witness points switch).",
      xLabel: "s (m)",
      yLabel: "dD/ds (m/m)",
      series: [
        { label: "GAP dD/ds", color: "#ffb347", width: 2 },
        { label: "Euclidean dd/ds", color: "#6ad1a3", width: 2 },
      ],
    });
    this.requests = new LatestWins(
      (i) => this.compute(i),
      (r) => this.apply(r),
    );
  }

  get requestsSent(): number {
    return this.requests.sent;
  }

  update(input: SweepInput): void {
    this.requests.submit(structuredClone(input));
  }

  private async compute(i: SweepInput): Promise<SweepData> {
    const poses = sweepPoses(i.b, i.sweep);
    const a = shapeRequest(i.a);
    const body = { pairs: poses.map((p) => ({ a, b: shapeRequest(p.shape) })), params: paramsBody(i.params, { gradient: true }) };
    const r = await api.post<{ results: GapResult[] }>("/api/gap/distance", body);
    const res = r.results;
    return {
      s: poses.map((p) => p.s),
      gap: res.map((x) => x.distance),
      euclid: res.map((x) => x.euclidean.signed_distance),
      dGap: res.map((x) => along(x.gradient_b, i.sweep)),
      dEuclid: res.map((x) => along(x.euclidean.gradient_b, i.sweep)),
    };
  }

  private apply(r: LatestResult<SweepInput, SweepData>): void {
    if (r.error !== undefined || !r.output) {
      // The curves drawn are those of the previous input: say so over them.
      const e = r.error ?? new Error("no sweep");
      const how = e instanceof ApiError && e.status >= 400 && e.status < 500 ? "refused" : "failed";
      for (const p of [this.dPlot, this.derivPlot]) p.setStale(`the sweep was ${how}: ${errorText(e)}`);
      this.onDone(e);
      return;
    }
    for (const p of [this.dPlot, this.derivPlot]) p.setStale(null);
    const d = r.output;
    this.last = d;
    const unit = r.input.sweep.motion === "translate" ? `B moves along ${r.input.sweep.axis} by s (m)` : `B turns about ${r.input.sweep.axis} by s (rad)`;
    this.dPlot.setTitle(`D — ${unit}`);
    this.derivPlot.setTitle(`dD/ds — ${unit}`);
    const su = r.input.sweep.motion === "translate" ? "m" : "rad";
    for (const p of [this.dPlot, this.derivPlot]) p.setAxisLabel(0, `s (${su})`);
    this.derivPlot.setAxisLabel(1, `dD/ds (m/${su})`);
    this.dPlot.setData(d.s, [d.gap, d.euclid]);
    this.derivPlot.setData(d.s, [d.dGap, d.dEuclid]);
    this.dPlot.setMarker(0);
    this.derivPlot.setMarker(0);
    this.onDone(null);
  }

  dispose(): void {
    this.requests.dispose();
    this.dPlot.dispose();
    this.derivPlot.dispose();
  }
}
