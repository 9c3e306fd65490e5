// window.distlab.cbf: read-only views of what the page shows and how long things took, for the
// browser tests and for measuring (nothing here changes the view's state).
import * as THREE from "three";
import { errorText } from "../../core/api";
import type { Viewport } from "../../core/viewport";
import type { Results } from "./results";
import type { Run } from "./run";
import type { CbfScene } from "./scene";
import type { CbfState } from "./state";
import type { Timeline } from "./timeline";
import type { DrawTimings } from "./timings";
import type { Metric } from "./types";

/** The view's parts as they are now (read at every hook access: they change with each run). */
export interface CbfParts {
  viewport: Viewport | null;
  state: CbfState;
  timeline: Timeline | null;
  run: Run | null;
  scene: CbfScene | null;
  shown: Metric[];
  results: Results | null;
  timings: DrawTimings;
  error: string | null;
}

export function installHooks(parts: () => CbfParts): () => void {
  const copy = <T>(x: T): T => structuredClone(x);
  const store = (m: Metric) => parts().run?.rollout(m)?.store;
  const hooks = Object.freeze({
    get state() {
      return copy(parts().state as unknown as Record<string, unknown>);
    },
    /** The step drawn now, and how many steps the timeline holds. */
    get step() {
      return parts().timeline?.step ?? 0;
    },
    get length() {
      return parts().timeline?.length ?? 0;
    },
    get playing() {
      return parts().timeline?.playing ?? false;
    },
    get rollouts() {
      return copy(rollouts(parts().run));
    },
    get lastError() {
      return parts().error;
    },
    record: (m: Metric) => copy(parts().run?.rollout(m)?.record ?? null),
    frame: (m: Metric, i: number) => copy(store(m)?.frame(i) ?? null),
    /** Per metric: the step drawn, the primitives' world poses and the pairs whose witnesses are shown. */
    drawn: () => copy(drawn(parts())),
    plots: () => {
      const p = parts().results?.plots;
      return copy(p ? { velocity: p.velocity.data(), distance: p.distance.data(), error: p.error.data() } : {});
    },
    /** The smoothness table as shown: the record's number behind every cell and its text. */
    table: () => copy(table(parts().results?.summary ?? null)),
    timings: () => {
      const { timings: t, results } = parts();
      const p = results?.plots;
      return copy({ arrivalToDrawnMs: t.arrivalToDrawnMs, drawMs: t.drawMs, plotRefreshes: p?.refreshes ?? 0, plotRefreshMs: p?.refreshMs ?? [] });
    },
    frameStats: () => parts().viewport?.frameStats() ?? null,
    resetFrameStats: () => parts().viewport?.resetFrameStats(),
  });
  const w = window as unknown as { distlab?: Record<string, unknown> };
  w.distlab ??= {};
  w.distlab.cbf = hooks;
  return () => {
    if (w.distlab?.cbf === hooks) delete w.distlab.cbf;
  };
}

function rollouts(run: Run | null) {
  return (run?.rollouts ?? []).map((r) => ({
    metric: r.metric,
    id: r.id,
    state: r.state,
    stepsDone: r.stepsDone,
    stepsTotal: r.stepsTotal,
    received: r.store?.received ?? 0,
    contiguous: r.store?.contiguous ?? 0,
    wsMessages: r.wsMessages,
    restPages: r.restPages,
    error: r.error ? errorText(r.error) : null,
  }));
}

function drawn({ scene, shown }: CbfParts) {
  const out: Record<string, { step: number; poses: number[]; witnesses: number[] }> = {};
  if (!scene) return out;
  for (const m of shown) {
    const w = scene.worlds[m];
    const poses: number[] = [];
    const p = new THREE.Vector3(), q = new THREE.Quaternion(), s = new THREE.Vector3();
    w.robot.children.forEach((c) => {
      c.matrix.decompose(p, q, s);
      poses.push(p.x, p.y, p.z, q.w, q.x, q.y, q.z);
    });
    out[m] = { step: w.step, poses, witnesses: [...w.witnesses.shown] };
  }
  return out;
}

function table(summary: Results["summary"] | null) {
  return [...(summary?.root.querySelectorAll<HTMLElement>("table.cbf-smoothness td[data-value]") ?? [])].map((c) => ({
    metric: c.dataset.metric ?? "",
    key: c.dataset.key ?? "",
    joint: Number(c.dataset.joint),
    value: Number(c.dataset.value),
    text: c.textContent ?? "",
  }));
}
