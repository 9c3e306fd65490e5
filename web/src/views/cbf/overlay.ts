// The text over the viewport: the colour legend naming each rollout drawn (and with Kelvin fields
// the object, its shells and the control points), and the readout with one line per shown rollout
// (time, clearance, the controller's smallest D and its pair, task error, the last joint's
// velocity, QP flags) and one per field (smallest h and where, the closest surface point and σ).
import type { FrameStore } from "./frames";
import type { Rollout } from "./rollout";
import type { RolloutSpec } from "./specs";

/** Adds the legend and an empty readout over the viewport. */
export function addOverlay(canvas: HTMLElement): { readout: HTMLDivElement; legend: HTMLDivElement } {
  const readout = document.createElement("div");
  readout.className = "readout cbf-readout";
  readout.dataset.testid = "cbf-readout";
  const legend = document.createElement("div");
  legend.className = "cbf-legend";
  legend.dataset.testid = "cbf-legend";
  canvas.append(readout, legend);
  return { readout, legend };
}

/** A legend line of the Kelvin fields: its colour (CSS) and text. */
export type LegendLine = [string, string];

/** One line per rollout drawn, in its colour, then the fields' lines. */
export function showLegend(el: HTMLElement, specs: RolloutSpec[], fieldLines: LegendLine[] = []): void {
  el.replaceChildren();
  const hex = (c: number) => `#${c.toString(16).padStart(6, "0")}`;
  for (const [color, text] of [
    ...specs.map((s) => [hex(s.color), `■ ${s.label} controller, ● ${s.metric === "gap" ? "its witness points" : "nearest points"}`]),
    ["#9fb6d6", "□ obstacles; axes = target frame"],
    ...fieldLines,
  ]) {
    const d = document.createElement("div");
    d.style.color = color;
    d.textContent = text;
    el.appendChild(d);
  }
}

/** The line of a rollout drawn at step k; `pair` names the closest pair shown. */
export function stepLine(s: RolloutSpec, k: number, store: FrameStore, pair: string): string {
  const f = (v: number, d = 4) => (Number.isFinite(v) ? v.toFixed(d) : "—");
  const flag = store.flags.data[k] === 2 ? "  QP held" : store.flags.data[k] === 1 ? "  QP relaxed" : "";
  return (
    `${s.label.padEnd(9)} t ${(k * store.dt).toFixed(2)} s  clearance ${f(store.minDistance.data[k])} m  ` +
    `min D ${f(store.minD.data[k])} m${pair ? ` (${pair})` : ""}  ‖r‖ ${f(store.taskError.data[k])}  u${store.dof} ${f(store.u.data[k * store.dof + store.dof - 1], 3)}${flag}`
  );
}

/** Per field of a rollout drawn at step k: its smallest h and where, and the closest surface point. */
export function fieldLines(s: RolloutSpec, k: number, store: FrameStore, names: string[], fields: Array<{ name: string; delta: number }>): string[] {
  const F = store.fieldCount,
    P = store.pointCount;
  const mm = (m: number) => (Number.isFinite(m) ? `${(1000 * m).toFixed(1)} mm` : "—");
  return fields.slice(0, F).map((field, f) => {
    let at = -1;
    for (let p = 0; p < P; p++) if (at < 0 || store.h.data[(k * F + f) * P + p] < store.h.data[(k * F + f) * P + at]) at = p;
    const h = store.minH.data[k * F + f];
    const c = store.closestPoint.data[k * F + f];
    return (
      `${s.short.padEnd(9)} ${field.name}: min h ${Number.isFinite(h) ? h.toFixed(3) : "—"} (δ ${field.delta}) at ${names[at] ?? "—"}; ` +
      `closest point σ ${store.closestSigma.data[k * F + f].toFixed(2)}, ${mm(store.closestDistance.data[k * F + f])} from ${names[c] ?? "—"}; ` +
      `allowed ${mm(store.allowedDistance.data[k * F + f])}, forbidden ${mm(store.forbiddenDistance.data[k * F + f])}`
    );
  });
}

/** The line of a rollout drawn at q0 (no frames of it yet), saying why. */
export function q0Line(s: RolloutSpec, r: Rollout | undefined): string {
  const why = !r ? "at q0" : r.state === "failed" ? "at q0 — the server refused the rollout" : r.state === "cancelled" ? "at q0 — not run" : "at q0 — waiting for frames…";
  return `${s.label.padEnd(9)} ${why}`;
}
