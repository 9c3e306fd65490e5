// The rollout plots in the bottom strip (paper Fig. 4 and friends): joint velocities u_j(t), the
// distances over time (true clearance and the controller's smallest D), the task error ‖r‖; every
// rollout of the run in the same plot (the first solid, the second dashed), one velocity series per
// joint of the run's robot, a line at the current time, a click seeks there; and every pair's
// distance at that time beside its margin (pair_bars.ts). Rebuilt per run (the series depend on
// the rollouts and the robot).
import { Plot, type PlotSeries } from "../../core/plot";
import { FieldPlots, type FieldSource } from "./field_plots";
import type { FrameStore } from "./frames";
import { PairBars, type PairSource } from "./pair_bars";
import type { RolloutSpec } from "./specs";

const JOINT_COLORS = ["#4e79a7", "#f28e2b", "#e15759", "#76b7b2", "#59a14f", "#edc948", "#b07aa1", "#ff9da7", "#9c755f"];
const hex = (c: number) => `#${c.toString(16).padStart(6, "0")}`;
const dash = (k: number) => (k > 0 ? [5, 3] : undefined);

export type PlotSource = PairSource & FieldSource;

export class RolloutPlots {
  readonly velocity: Plot;
  readonly distance: Plot;
  readonly error: Plot;
  readonly pairs: PairBars;
  /** The Kelvin fields' plots, once a rollout of the run streams fields. */
  fields: FieldPlots | null = null;
  private time: number | null = null;
  private timer = 0;
  private dirty = false;
  /** Plot refreshes and their JS time (data copy + uPlot setData), for measurements. */
  refreshes = 0;
  refreshMs: number[] = [];

  constructor(
    private readonly container: HTMLElement,
    readonly specs: RolloutSpec[],
    /** The robot's joints (one velocity series each per rollout). */
    readonly dof: number,
    joint: number,
    private readonly onPick: (t: number) => void,
  ) {
    const vSeries: PlotSeries[] = [];
    for (let j = 0; j < dof; j++)
      specs.forEach((s, k) =>
        vSeries.push({
          label: `u${j + 1} ${s.short}`,
          color: JOINT_COLORS[j % JOINT_COLORS.length],
          dash: dash(k),
          width: k === 0 ? 1.6 : 1.2,
          show: joint === 0 || joint === j + 1,
        }),
      );
    const title = specs.length === 2 ? `${specs[0].label} solid, ${specs[1].label} dashed` : (specs[0]?.label ?? "");
    this.velocity = new Plot(container, {
      title: `joint velocities u (rad/s) — ${title}`,
      caption: "Each joint's velocity command u_j from the controller's QP, one colour per joint.",
      xLabel: "t (s)",
      yLabel: "u (rad/s)",
      series: vSeries,
      digits: 4,
      legendValues: false,
    });
    this.velocity.root.style.flex = "1.5";
    const dSeries: PlotSeries[] = [];
    for (const s of specs) {
      dSeries.push({ label: `clearance ${s.short}`, color: hex(s.color), width: 2 });
      dSeries.push({ label: `min D ${s.short}`, color: hex(s.color), dash: [2, 3], width: 1.2 });
    }
    this.distance = new Plot(container, {
      title: "distance (m)",
      caption:
        "clearance (solid): the true Euclidean distance between robot and obstacles; min D (dotted): the smallest distance over the controller's pairs (GAP D or Euclidean d), on one axis.",
      xLabel: "t (s)",
      yLabel: "distance (m)",
      series: dSeries,
      digits: 5,
      legendValues: false,
    });
    this.error = new Plot(container, {
      title: "task error ‖r‖",
      xLabel: "t (s)",
      caption: "The norm of the task error r (end-effector position in m, orientation as 1 − cos), log scale.",
      yLabel: "‖r‖ (m, 1 − cos)",
      yLog: true,
      series: specs.map((s, k) => ({ label: `‖r‖ ${s.short}`, color: hex(s.color), dash: dash(k), width: 1.6 })),
      digits: 5,
      legendValues: false,
    });
    this.error.root.style.flex = "1";
    for (const p of [this.velocity, this.distance, this.error]) p.onPick(onPick);
    this.pairs = new PairBars(container, specs);
  }

  /** Only joint j (1 … dof) or all (0). */
  showJoint(joint: number): void {
    let i = 0;
    for (let j = 0; j < this.dof; j++) for (let k = 0; k < this.specs.length; k++) this.velocity.setShown(i++, joint === 0 || joint === j + 1);
  }

  /** Coalesced: at most ~8 refreshes a second while frames stream in. */
  update(sources: PlotSource[]): void {
    this.dirty = true;
    if (this.timer) return;
    this.timer = window.setTimeout(() => {
      this.timer = 0;
      if (this.dirty) this.refresh(sources);
    }, 120);
  }

  refresh(sources: PlotSource[]): void {
    const t0 = performance.now();
    this.dirty = false;
    this.refreshes++;
    const n = Math.max(0, ...sources.map((s) => s.store?.contiguous ?? 0));
    const dt = sources.find((s) => s.store)?.store?.dt ?? 0.01;
    const x = Float64Array.from({ length: n }, (_, i) => i * dt);
    const bySource = this.specs.map((sp) => sources.find((s) => s.key === sp.key)?.store ?? null);
    const pad = (store: FrameStore | null, f: (s: FrameStore, len: number) => ArrayLike<number>, positive = false): Array<number | null> => {
      const len = store?.contiguous ?? 0;
      const out: Array<number | null> = new Array(n).fill(null);
      if (!store) return out;
      const v = f(store, len);
      for (let i = 0; i < len; i++) out[i] = Number.isFinite(v[i]) && (!positive || v[i] > 0) ? v[i] : null;
      return out;
    };
    const vel: Array<Array<number | null>> = [];
    for (let j = 0; j < this.dof; j++) for (const s of bySource) vel.push(pad(s, (st, len) => st.uSeries(j, len)));
    this.velocity.setData(x, vel);
    const dist: Array<Array<number | null>> = [];
    for (const s of bySource) {
      dist.push(pad(s, (st, len) => st.scalarSeries(st.minDistance, len)));
      dist.push(pad(s, (st, len) => st.scalarSeries(st.minD, len)));
    }
    this.distance.setData(x, dist);
    this.error.setData(
      x,
      bySource.map((s) => pad(s, (st, len) => st.scalarSeries(st.taskError, len), true)),
    );
    this.pairs.setSources(sources);
    if (!this.fields && bySource.some((st) => st && st.fieldCount > 0)) {
      this.fields = new FieldPlots(this.container, this.specs, this.onPick);
      this.fields.setTime(this.time);
    }
    this.fields?.refresh(sources, x);
    this.refreshMs.push(performance.now() - t0);
    if (this.refreshMs.length > 1000) this.refreshMs.splice(0, 500);
  }

  setTime(t: number | null): void {
    this.time = t;
    for (const p of [this.velocity, this.distance, this.error]) p.setMarker(t);
    this.pairs.setTime(t);
    this.fields?.setTime(t);
  }

  dispose(): void {
    clearTimeout(this.timer);
    this.velocity.dispose();
    this.distance.dispose();
    this.error.dispose();
    this.pairs.dispose();
    this.fields?.dispose();
  }
}
