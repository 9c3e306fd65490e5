// The run's numbers beside the 3D view: the plots in the bottom strip (rebuilt per run: their
// series depend on the metrics run) and the summary in the panel, kept up with the streaming run.
import { RolloutPlots } from "./plots";
import type { Run } from "./run";
import { rolloutNote, Summary } from "./summary";
import type { Metric } from "./types";

export class Results {
  plots: RolloutPlots | null = null;
  readonly summary: Summary;

  constructor(
    private readonly bottom: HTMLElement,
    panelExtra: HTMLElement,
    /** A click on a plot at time t. */
    private readonly pick: (t: number) => void,
  ) {
    this.summary = new Summary(panelExtra);
  }

  /** Empty plots for these metrics, showing joint `joint` (0 = all). */
  build(metrics: Metric[], joint: number): void {
    this.plots?.dispose();
    this.plots = new RolloutPlots(this.bottom, metrics, joint, this.pick);
  }

  /** No run: nothing plotted, no numbers. */
  clear(): void {
    this.plots?.refresh([]);
    this.summary.show([]);
  }

  /** A run of these metrics started: their numbers come when each rollout ends. */
  started(metrics: Metric[]): void {
    this.summary.show(metrics.map((metric) => ({ metric, record: null })));
  }

  /** New frames streamed in (the plots coalesce their refreshes). */
  frames(run: Run): void {
    this.plots?.update(sources(run));
  }

  /** A rollout ended: every frame plotted, and its record's numbers (or why there are none). */
  ended(run: Run): void {
    this.plots?.refresh(sources(run));
    this.summary.show(run.rollouts.map((r) => ({ metric: r.metric, record: r.record, note: rolloutNote(r) })));
  }

  setTime(t: number | null): void {
    this.plots?.setTime(t);
  }

  showJoint(joint: number): void {
    this.plots?.showJoint(joint);
  }

  dispose(): void {
    this.plots?.dispose();
    this.summary.dispose();
  }
}

function sources(run: Run) {
  return run.rollouts.map((r) => ({ metric: r.metric, store: r.store }));
}
