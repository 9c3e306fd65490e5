// The text over the viewport: the colour legend, and the readout with one line per shown metric
// (time, clearance, the controller's smallest D and its pair, task error, u7, QP flags).
import { COLORS } from "./scene";
import type { FrameStore } from "./frames";
import type { Rollout } from "./rollout";
import { METRIC_NAMES, type Metric } from "./types";

/** Adds the legend and an empty readout over the viewport; returns the readout. */
export function addOverlay(canvas: HTMLElement): HTMLDivElement {
  const readout = document.createElement("div");
  readout.className = "readout cbf-readout";
  readout.dataset.testid = "cbf-readout";
  canvas.append(readout, legend());
  return readout;
}

function legend(): HTMLElement {
  const el = document.createElement("div");
  el.className = "cbf-legend";
  const hex = (c: number) => `#${c.toString(16).padStart(6, "0")}`;
  for (const [color, text] of [
    [hex(COLORS.gap), "■ GAP controller, ● its witness points"],
    [hex(COLORS.euclidean), "■ Euclidean controller, ● nearest points"],
    ["#9fb6d6", "□ obstacles; axes = target frame"],
  ]) {
    const d = document.createElement("div");
    d.style.color = color;
    d.textContent = text;
    el.appendChild(d);
  }
  return el;
}

/** The line of a metric drawn at step k of its rollout; `pair` names the closest pair shown. */
export function stepLine(m: Metric, k: number, store: FrameStore, pair: string): string {
  const f = (v: number, d = 4) => (Number.isFinite(v) ? v.toFixed(d) : "—");
  const flag = store.flags.data[k] === 2 ? "  QP held" : store.flags.data[k] === 1 ? "  QP relaxed" : "";
  return (
    `${METRIC_NAMES[m].padEnd(9)} t ${(k * store.dt).toFixed(2)} s  clearance ${f(store.minDistance.data[k])} m  ` +
    `min D ${f(store.minD.data[k])} m${pair ? ` (${pair})` : ""}  ‖r‖ ${f(store.taskError.data[k])}  u7 ${f(store.u.data[k * 7 + 6], 3)}${flag}`
  );
}

/** The line of a metric drawn at q0 (no frames of it yet), saying why. */
export function q0Line(m: Metric, r: Rollout | undefined): string {
  const why = !r ? "at q0" : r.state === "failed" ? "at q0 — the server refused the rollout" : r.state === "cancelled" ? "at q0 — not run" : "at q0 — waiting for frames…";
  return `${METRIC_NAMES[m].padEnd(9)} ${why}`;
}
