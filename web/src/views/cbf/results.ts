// The run's numbers beside the 3D view: the plots in the bottom strip (rebuilt per run: their
// series depend on the metrics run) and the summary in the panel, kept up with the streaming run.
import { RolloutPlots } from "./plots";
import type { Run } from "./run";
import type { RolloutSpec } from "./specs";
import { rolloutNote, Summary } from "./summary";

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

  /** Empty plots for these rollouts of a robot with `dof` joints, showing joint `joint` (0 = all). */
  build(specs: RolloutSpec[], dof: number, joint: number): void {
    this.plots?.dispose();
    this.plots = new RolloutPlots(this.bottom, specs, dof, joint, this.pick);
  }

  /** No run: nothing plotted, no numbers. */
  clear(): void {
    this.plots?.refresh([]);
    this.summary.show([]);
  }

  /** A run of these rollouts started: their numbers come when each rollout ends. */
  started(specs: RolloutSpec[]): void {
    this.summary.show(specs.map((spec) => ({ spec, record: null })));
  }

  /** New frames streamed in (the plots coalesce their refreshes). */
  frames(run: Run): void {
    this.plots?.update(sources(run));
  }

  /** A rollout ended: every frame plotted, and its record's numbers (or why there are none). */
  ended(run: Run): void {
    this.plots?.refresh(sources(run));
    this.summary.show(run.rollouts.map((r) => ({ spec: r.spec, record: r.record, note: rolloutNote(r) })));
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
  return run.rollouts.map((r) => ({ key: r.spec.key, store: r.store, status: r.status, record: r.record }));
}
