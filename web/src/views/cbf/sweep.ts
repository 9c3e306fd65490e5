// A parameter sweep from the view (POST /api/cbf/sweeps): one params key over a list of values as
// one server job (progress and cancel in the shell's progress box), then each run's final distance
// to the target, smallest clearance and total variation of u plotted against the parameter.
import { api } from "../../core/api";
import { Plot } from "../../core/plot";
import type { PostResponse } from "../../core/wire";
import type { CbfSweep, CbfSweepEntry } from "./types";

/** A sweep as GET /api/cbf/sweeps/{id} answers, with its job as the view last saw it. */
export type SweepJson = CbfSweep;

const ENDED = ["succeeded", "failed", "cancelled"];

/** Posts the sweep and follows its job until it ends (progress(stage, fraction) meanwhile). */
export async function runSweep(body: Record<string, unknown>, progress: (s: SweepJson) => void, stopped: () => boolean): Promise<SweepJson> {
  const r = await api.post<PostResponse<"/api/cbf/sweeps">>("/api/cbf/sweeps", body);
  let s: SweepJson = { ...r.sweep, job: r.job };
  for (let guard = 0; guard < 100000 && !stopped(); guard++) {
    progress(s);
    if (s.job && ENDED.includes(s.job.state)) return s;
    await new Promise((res) => setTimeout(res, 300));
    s = await api.get<SweepJson>(`/api/cbf/sweeps/${s.id}`);
  }
  return s;
}

/** Values as typed: numbers separated by commas or spaces (null: something else is there). */
export function parseValues(text: string): number[] | null {
  const parts = text.split(/[\s,;]+/).filter((p) => p !== "");
  const v = parts.map(Number);
  return v.length && v.every(Number.isFinite) ? v : null;
}

/** Whether values are drawn on a log axis: all positive and spanning more than a decade (a margin
 *  swept over 1e-4 … 2e-3 would put all but one run in the first tenth of a linear axis). */
export function logSpaced(values: number[]): boolean {
  const lo = Math.min(...values),
    hi = Math.max(...values);
  return values.length > 1 && lo > 0 && hi / lo > 10;
}

/** The sweep's plot in the bottom strip: cm against the parameter, total variation on the right axis. */
export class SweepPlot {
  readonly plot: Plot;
  constructor(container: HTMLElement, s: SweepJson) {
    // The view sweeps numbers (parseValues); the server echoes each run's value as sent.
    const at = (x: CbfSweepEntry) => Number(x.value);
    const xLog = logSpaced(s.entries.map(at));
    this.plot = new Plot(container, {
      title: `sweep of ${s.parameter} (${s.entries.length} of ${s.values.length} runs)`,
      caption:
        "One rollout per value of the parameter: the end-effector's final distance to its target and the smallest clearance (cm, left axis), and the summed total variation of the joint velocities u (right axis).",
      xLabel: xLog ? `${s.parameter} (log axis)` : s.parameter,
      xLog,
      yLabel: "distance (cm)",
      y2Label: "TV of u (rad/s)",
      series: [
        { label: "final |p − p_d| (cm)", color: "#ffb347", width: 2 },
        { label: "min clearance (cm)", color: "#6ad1a3", width: 2 },
        { label: "Σ TV of u", color: "#8ab4ff", scale: "y2", dash: [5, 3], width: 1.6 },
      ],
      digits: 4,
    });
    this.plot.root.dataset.testid = "cbf-sweep-plot";
    this.plot.root.style.flex = "1.4";
    const e = [...s.entries].sort((a, b) => at(a) - at(b));
    this.plot.setData(e.map(at), [e.map((x) => 100 * x.position_error), e.map((x) => (x.min_clearance === null ? null : 100 * x.min_clearance)), e.map((x) => x.total_variation)]);
  }
  /** The curves are of an earlier sweep than the one asked for (refused: the reason). */
  setStale(reason: string | null): void {
    this.plot.setStale(reason);
  }

  dispose(): void {
    this.plot.dispose();
  }
}
