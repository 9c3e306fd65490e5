// One press of "run": a rollout per spec (metric and GAP distance) of the same scenario and duration, one after the other
// (so each one's per-step timing is measured without the other competing for the 2 cores), with
// a combined progress, one cancel for all, and the first API error reported (the rest not sent).
import { Rollout, type RobotSize, type RolloutEvents, type RolloutRequest } from "./rollout";
import type { RolloutSpec } from "./specs";
import type { CbfFeasibility, CbfFinalState } from "./types";

export interface RunEvents {
  frames(r: Rollout, added: number, arrived: number): void;
  progress(run: Run): void;
  /** A rollout ended (finished, cancelled or failed). */
  ended(r: Rollout): void;
  /** The whole run is over (all rollouts ended, or one failed to start). */
  done(run: Run, error: unknown | null): void;
  /** A rollout's Kelvin objects arrived (or failed to). */
  fields(r: Rollout): void;
}

export class Run {
  readonly rollouts: Rollout[];
  cancelled = false;
  finished = false;
  private disposed = false;

  constructor(
    readonly scenario: RolloutRequest["scenario"],
    readonly specs: RolloutSpec[],
    readonly duration: number,
    /** The scenario's Kelvin fields (0: none). */
    readonly fieldCount: number,
    robot: RobotSize,
    private readonly events: RunEvents,
  ) {
    const ev: RolloutEvents = {
      frames: (r, added, arrived) => !this.disposed && events.frames(r, added, arrived),
      progress: () => !this.disposed && events.progress(this),
      ended: (r) => !this.disposed && this.onEnded(r),
      error: () => undefined, // reported through ended/done
      fields: (r) => !this.disposed && events.fields(r),
    };
    this.rollouts = specs.map((spec) => new Rollout({ scenario, spec, duration, fieldCount }, robot, ev));
  }

  get running(): boolean {
    return !this.finished;
  }

  /** Fraction of all steps of all rollouts computed so far. */
  get fraction(): number {
    const total = this.rollouts.reduce((s, r) => s + (r.stepsTotal || Math.round(this.duration / 0.01)), 0);
    const done = this.rollouts.reduce((s, r) => s + (r.state === "finished" ? r.stepsTotal : r.stepsDone), 0);
    return total > 0 ? done / total : 0;
  }

  /** The rollout of a spec's key ("gap", "euclidean", "gap2", …). */
  rollout(key: string): Rollout | undefined {
    return this.rollouts.find((r) => r.spec.key === key);
  }

  async start(): Promise<void> {
    await this.startNext();
  }

  private async startNext(): Promise<void> {
    const next = this.rollouts.find((r) => r.state === "queued" && !r.id);
    if (!next || this.cancelled || this.disposed) {
      this.end(null);
      return;
    }
    try {
      await next.start();
      this.events.progress(this);
    } catch (e) {
      this.end(e);
    }
  }

  private onEnded(r: Rollout): void {
    this.events.ended(r);
    if (r.state === "failed") {
      this.end(r.error);
      return;
    }
    void this.startNext();
  }

  private end(error: unknown | null): void {
    if (this.finished) return;
    this.finished = true;
    for (const r of this.rollouts) if (!r.id && r.state === "queued") r.state = "cancelled"; // never started
    if (!this.disposed) this.events.done(this, error);
  }

  async cancel(): Promise<void> {
    this.cancelled = true;
    await Promise.all(this.rollouts.map((r) => r.cancel()));
  }

  dispose(): void {
    this.disposed = true;
    for (const r of this.rollouts) {
      if (r.running) void r.cancel();
      r.dispose();
    }
  }
}

/** The rollout being computed (or waiting to be). */
function current(run: Run): Rollout | undefined {
  return run.rollouts.find((r) => r.running && r.id) ?? run.rollouts.find((r) => r.running);
}

/** Whether a rollout's job is still preparing its Kelvin fields (a stage before "rollout"). */
export function preparing(r: Rollout | undefined): boolean {
  return !!r && r.running && !!r.status?.kelvin && r.stepsDone === 0 && r.stage !== "" && r.stage !== "rollout";
}

/** The progress bar's label: the rollout being computed and its steps, or the field it prepares. */
export function progressLabel(run: Run): string {
  const r = current(run);
  if (r && preparing(r)) {
    const names = r.status!.kelvin!.fields.map((f) => `“${f.name}”`).join(", ");
    return `${r.spec.label} rollout: preparing the Kelvin field ${names} — ${r.stage} ${Math.round(100 * r.stageFraction)} %`;
  }
  const what = r ? `${r.spec.label} rollout` : "rollout";
  const steps = r ? ` ${r.stepsDone} / ${r.stepsTotal || "…"} steps` : "";
  return `${what}:${steps}`;
}

/** The progress bar's fraction: the preparation's while the current rollout prepares its fields. */
export function progressFraction(run: Run): number {
  const r = current(run);
  return r && preparing(r) ? r.stageFraction : run.fraction;
}

/** The status line while a run computes. */
export function runningStatus(run: Run): string {
  if (preparing(current(run)))
    return "preparing the scenario's Kelvin field (meshed and factored once, then read from the server's cache) — the rollout starts when it is ready (Esc cancels)";
  return `computing ${run.specs.map((s) => s.label).join(", then ")} — frames stream in as they are computed (Esc cancels)`;
}

const cm = (m: number): string => `${(100 * m).toFixed(2)} cm`;
const num = (v: number): string => (Math.abs(v) < 1e-3 && v !== 0 ? v.toExponential(2) : v.toPrecision(3));

/** Why a rollout stopped where it did: its distance to the target and the rows holding it. */
export function stopReason(final: CbfFinalState | undefined, reached: boolean): string {
  if (!final) return reached ? "reached the target" : "target not reached";
  const where = reached ? "reached the target" : `stopped ${cm(final.position_error)} from the target`;
  const rows = final.active
    .filter((a) => a.kind === "pair" || a.kind === "field")
    .slice(0, 2)
    .map((a) => {
      if (a.kind === "field") return `${a.name} (h ${num(a.distance)} vs δ ${num(a.margin)})`;
      const conv = a.converged_distance !== null ? `, converged D ${num(a.converged_distance)}` : "";
      const clear = a.clearance !== null ? `, clearance ${cm(a.clearance)}` : "";
      return `${a.name} (D ${num(a.distance)} vs δ ${num(a.margin)}${clear}${conv})`;
    });
  const limits = final.active.filter((a) => a.kind === "joint_limit").map((a) => a.name);
  const held = [...rows, ...limits];
  return `${where}${held.length && !reached ? `; active rows: ${held.join(", ")}` : ""}`;
}

/** What the exact target allows (POST /api/cbf/feasibility). */
export function feasibilityText(f: CbfFeasibility | null): string {
  if (!f) return "";
  if (!f.reachable) return "exact target: no configuration within the joint limits reaches it";
  const m = f.margins!;
  return (
    `exact target: best clearance ${cm(f.clearance!)} (${f.limiting_pair}) ${f.euclidean_feasible ? "≥" : "<"} Euclidean δ ${cm(m.euclidean)}; ` +
    `GAP D there ${num(f.gap_distance!)} ${f.gap_feasible ? "≥" : "<"} δ ${num(m.gap)}`
  );
}

/** The status line after a run: how each rollout ended, whether it reached the target and if not why. */
export function endedStatus(run: Run, feasibility: CbfFeasibility | null = null): string {
  const parts = run.rollouts.map((r) => `${r.spec.label} ${r.state}${r.record ? ": " + stopReason(r.record.summary.final, r.record.summary.reached) : ""}`);
  const f = feasibilityText(feasibility);
  return [...parts, ...(f ? [f] : [])].join(" · ");
}
