// window.distlab.cbf: read-only views of what the page shows and how long things took, for the
// browser tests and for measuring (nothing here changes the view's state).
import type { Viewport } from "../../core/viewport";
import type { CbfRecord, Metric } from "./types";

export interface CbfHookSource {
  readonly viewport: Viewport | null;
  stateJson(): Record<string, unknown>;
  step(): number;
  length(): number;
  playing(): boolean;
  rollouts(): Array<{ metric: Metric; id: string | null; state: string; stepsDone: number; stepsTotal: number; received: number; contiguous: number; wsMessages: number; restPages: number; error: string | null }>;
  record(metric: Metric): CbfRecord | null;
  frame(metric: Metric, i: number): unknown;
  drawn(): Record<string, { step: number; poses: number[]; witnesses: number[] }>;
  plotData(): Record<string, { labels: string[]; x: number[]; y: Array<Array<number | null>> }>;
  table(): Array<{ metric: string; key: string; joint: number; value: number; text: string }>;
  timings(): { arrivalToDrawnMs: number[]; drawMs: number[]; plotRefreshes: number; plotRefreshMs: number[] };
  lastError(): string | null;
}

export function installHooks(v: CbfHookSource): () => void {
  const copy = <T>(x: T): T => structuredClone(x);
  const hooks = Object.freeze({
    get state() {
      return copy(v.stateJson());
    },
    /** The step drawn now, and how many steps the timeline holds. */
    get step() {
      return v.step();
    },
    get length() {
      return v.length();
    },
    get playing() {
      return v.playing();
    },
    get rollouts() {
      return copy(v.rollouts());
    },
    get lastError() {
      return v.lastError();
    },
    record: (m: Metric) => copy(v.record(m)),
    frame: (m: Metric, i: number) => copy(v.frame(m, i)),
    /** Per metric: the step drawn, the primitives' world poses and the pairs whose witnesses are shown. */
    drawn: () => copy(v.drawn()),
    plots: () => copy(v.plotData()),
    /** The smoothness table as shown: the record's number behind every cell and its text. */
    table: () => copy(v.table()),
    timings: () => copy(v.timings()),
    frameStats: () => v.viewport?.frameStats() ?? null,
    resetFrameStats: () => v.viewport?.resetFrameStats(),
  });
  const w = window as unknown as { distlab?: Record<string, unknown> };
  w.distlab ??= {};
  w.distlab.cbf = hooks;
  return () => {
    if (w.distlab?.cbf === hooks) delete w.distlab.cbf;
  };
}
