// The Kelvin fields' plots (issue 33), added to the strip when a run's rollouts have fields: the
// smallest h over the control points with the barrier's δ, and the distance of the control points
// to the object's allowed faces (σ > δ at every corner: where the pads may touch) and forbidden
// faces (σ < 0) with the safety distance the field keeps from the latter. Every rollout of the run
// in the same plot (the first solid, the second dashed), as the other plots.
import { Plot, type PlotSeries } from "../../core/plot";
import type { FrameStore } from "./frames";
import type { RolloutSpec } from "./specs";
import type { CbfRecord, CbfRolloutStatus } from "./types";

const hex = (c: number) => `#${c.toString(16).padStart(6, "0")}`;
const dash = (k: number) => (k > 0 ? [5, 3] : undefined);

export interface FieldSource {
  key: string;
  store: FrameStore | null;
  status: Pick<CbfRolloutStatus, "kelvin"> | null;
  /** The record, once the rollout ended (its safety distances). */
  record: Pick<CbfRecord, "kelvin"> | null;
}

/** A per-field series' smallest value over the fields at each step (NaN where none has one). */
function minOverFields(store: FrameStore, g: FrameStore["minH"], n: number): Float64Array {
  const out = new Float64Array(n).fill(NaN);
  for (let f = 0; f < store.fieldCount; f++) {
    const v = store.fieldSeries(g, f, n);
    for (let i = 0; i < n; i++) if (Number.isNaN(out[i]) || v[i] < out[i]) out[i] = v[i];
  }
  return out;
}

export class FieldPlots {
  readonly h: Plot;
  readonly distance: Plot;

  constructor(
    container: HTMLElement,
    readonly specs: RolloutSpec[],
    onPick: (t: number) => void,
  ) {
    const hSeries: PlotSeries[] = [];
    const dSeries: PlotSeries[] = [];
    specs.forEach((s, k) => {
      hSeries.push({ label: `min h ${s.short}`, color: hex(s.color), dash: dash(k), width: 1.8 });
      hSeries.push({ label: `δ ${s.short}`, color: "#ff3b30", dash: [2, 3], width: 1.2 });
      dSeries.push({ label: `allowed ${s.short}`, color: hex(s.color), dash: dash(k), width: 1.8 });
      dSeries.push({ label: `forbidden ${s.short}`, color: "#ff8a80", dash: dash(k), width: 1.4 });
      dSeries.push({ label: `safety ${s.short}`, color: "#ff3b30", dash: [2, 3], width: 1.2 });
    });
    this.h = new Plot(container, {
      title: "Kelvin barrier h",
      caption: "min h: the smallest semantics-aware distance h over the control points (dimensionless); δ (dotted red): the barrier's level, every row keeps h ≥ δ.",
      xLabel: "t (s)",
      yLabel: "h",
      series: hSeries,
      digits: 4,
      legendValues: false,
    });
    this.distance = new Plot(container, {
      title: "distance to the object (m)",
      caption:
        "allowed: the control points' smallest distance to the faces where contact is allowed (σ > δ); forbidden: to the faces where it is not (σ < 0); safety (dotted red): the distance the field keeps from the forbidden faces (from the record).",
      xLabel: "t (s)",
      yLabel: "distance (m)",
      series: dSeries,
      digits: 5,
      legendValues: false,
      yLog: true,
    });
    for (const p of [this.h, this.distance]) p.onPick(onPick);
  }

  refresh(sources: FieldSource[], x: Float64Array): void {
    const n = x.length;
    const bySource = this.specs.map((sp) => sources.find((s) => s.key === sp.key) ?? null);
    const column = (store: FrameStore | null, v: (s: FrameStore, len: number) => ArrayLike<number>): Array<number | null> => {
      const out: Array<number | null> = new Array(n).fill(null);
      if (!store || store.fieldCount === 0) return out;
      const len = Math.min(store.contiguous, n);
      const values = v(store, len);
      for (let i = 0; i < len; i++) out[i] = Number.isFinite(values[i]) ? values[i] : null;
      return out;
    };
    const constant = (value: number | null | undefined, len: number): Array<number | null> =>
      Array.from({ length: n }, (_, i) => (i < len && value !== null && value !== undefined && Number.isFinite(value) ? value : null));
    const h: Array<Array<number | null>> = [];
    const d: Array<Array<number | null>> = [];
    for (const s of bySource) {
      const store = s?.store ?? null;
      const len = store?.fieldCount ? store.contiguous : 0;
      const delta = s?.status?.kelvin ? Math.max(...s.status.kelvin.fields.map((f) => f.delta)) : null;
      const safety = s?.record?.kelvin ? Math.min(...s.record.kelvin.fields.map((f) => f.safety_distance ?? Infinity)) : null;
      h.push(column(store, (st, m) => minOverFields(st, st.minH, m)));
      h.push(constant(delta, len));
      d.push(column(store, (st, m) => minOverFields(st, st.allowedDistance, m)));
      d.push(column(store, (st, m) => minOverFields(st, st.forbiddenDistance, m)));
      d.push(constant(safety, len));
    }
    this.h.setData(x, h);
    this.distance.setData(x, d);
  }

  setTime(t: number | null): void {
    this.h.setMarker(t);
    this.distance.setMarker(t);
  }

  dispose(): void {
    this.h.dispose();
    this.distance.dispose();
  }
}
