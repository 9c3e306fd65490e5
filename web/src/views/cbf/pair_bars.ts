// The distance of every pair at the selected step (issue 32): one bar per pair of each shown
// rollout (the controller's D: GAP or Euclidean, from the streamed frames), and the margin δ its
// CBF row keeps it above (δ obstacle for a robot–obstacle pair, δ self for a self pair, the
// rollout's metric's), as a level over each pair's bars. Log scale: D and δ differ by decades.
import { Plot, type PlotSeries } from "../../core/plot";
import type { FrameStore } from "./frames";
import type { RolloutSpec } from "./specs";
import type { CbfRolloutStatus } from "./types";

const hex = (c: number) => `#${c.toString(16).padStart(6, "0")}`;

export interface PairSource {
  key: string;
  store: FrameStore | null;
  /** The rollout as the server accepted it: its pairs and margins (null before). */
  status: Pick<CbfRolloutStatus, "pairs" | "margins"> | null;
}

export class PairBars {
  readonly plot: Plot;
  private names: string[] = [];
  private sources: PairSource[] = [];
  private time: number | null = null;
  private shown = "";

  constructor(
    container: HTMLElement,
    readonly specs: RolloutSpec[],
  ) {
    const series: PlotSeries[] = [];
    specs.forEach((s, k) => {
      series.push({ label: `D ${s.short}`, color: hex(s.color), kind: "bars", align: specs.length === 2 ? (k === 0 ? -1 : 1) : 0, width: 1 });
      series.push({ label: `δ ${s.short}`, color: hex(s.color), kind: "levels", dash: [4, 2], width: 1.5 });
    });
    this.plot = new Plot(container, {
      title: "pair distances",
      caption:
        "Bars: each pair's distance D at the selected step (GAP D or Euclidean d; an overlapping pair has none). Dashed: the margin δ its CBF row keeps it above (δ obstacle, or δ self for a self pair).",
      xLabel: "pair (#)",
      yLabel: "D (m)",
      yLog: true,
      series,
      digits: 5,
      categories: (i) => this.names[i] ?? String(i),
    });
    this.plot.root.style.flex = "1.1";
    this.plot.root.dataset.testid = "cbf-pair-bars";
  }

  /** The rollouts' frames and statuses (new frames, a new rollout). */
  setSources(sources: PairSource[]): void {
    this.sources = sources;
    this.refresh(true);
  }

  /** The selected time (null: no step). */
  setTime(t: number | null): void {
    this.time = t;
    this.refresh(false);
  }

  private refresh(changed: boolean): void {
    const bySource = this.specs.map((sp) => this.sources.find((s) => s.key === sp.key) ?? null);
    const named = bySource.find((s) => s?.status)?.status ?? null;
    const n = named?.pairs.length ?? 0;
    const dt = bySource.find((s) => s?.store)?.store?.dt ?? 0.01;
    const want = this.time === null ? -1 : Math.round(this.time / dt);
    // Each rollout's step: the selected one, or its last computed one while it lags behind.
    const steps = bySource.map((s) => (s?.store && s.store.hasPairs && s.store.contiguous > 0 && want >= 0 ? Math.min(want, s.store.contiguous - 1) : -1));
    const key = `${n}|${steps.join(",")}`;
    if (!changed && key === this.shown) return;
    this.shown = key;
    this.names = named ? named.pairs.map((p) => p.name) : [];
    const ys: Array<Array<number | null>> = [];
    bySource.forEach((s, k) => {
      const store = s?.store ?? null;
      const step = steps[k];
      const pairs = s?.status?.pairs ?? [];
      ys.push(
        Array.from({ length: n }, (_, i) => {
          if (!store || step < 0 || i >= store.pairCount) return null;
          const d = store.distance.data[step * store.pairCount + i];
          return d > 0 ? d : null;
        }),
      );
      const m = s?.status?.margins;
      ys.push(Array.from({ length: n }, (_, i) => (m && i < pairs.length ? (pairs[i].self ? m.self : m.obstacle) : null)).map((v) => (v !== null && v > 0 ? v : null)));
    });
    this.plot.setData(
      Array.from({ length: n }, (_, i) => i),
      ys,
    );
    const shownStep = Math.max(...steps);
    this.plot.setTitle(shownStep >= 0 ? `pair distances at t = ${(shownStep * dt).toFixed(2)} s` : "pair distances");
  }

  dispose(): void {
    this.plot.dispose();
  }
}
