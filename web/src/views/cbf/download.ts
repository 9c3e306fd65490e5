// A finished rollout's record as files: the JSON the server returned (GET
// /api/cbf/rollouts/{id}/record, as `distlab cbf` writes it) and a CSV of its per-step series.
import type { CbfRecord } from "./types";

/** One row per step: t, q_1…q_n, u_1…u_n, task_error, min_distance (empty when not audited). */
export function recordCsv(record: CbfRecord): string {
  const n = record.u[0]?.length ?? 0;
  const joints = Array.from({ length: n }, (_, j) => j + 1);
  const lines = [["t", ...joints.map((j) => `q${j}`), ...joints.map((j) => `u${j}`), "task_error", "min_distance"].join(",")];
  record.t.forEach((t, i) => {
    const q = record.q?.[i] ?? [];
    lines.push([t, ...q, ...record.u[i], record.task_error[i], record.min_distance[i] ?? ""].join(","));
  });
  return lines.join("\n") + "\n";
}

function save(name: string, type: string, text: string): void {
  const a = document.createElement("a");
  a.href = URL.createObjectURL(new Blob([text], { type }));
  a.download = name;
  a.click();
  window.setTimeout(() => URL.revokeObjectURL(a.href), 2000);
}

/** "GAP exact record: JSON · CSV" links that download the record of the rollout `key`. */
export function downloadLinks(key: string, label: string, record: CbfRecord): HTMLElement {
  const p = document.createElement("p");
  p.className = "cbf-download";
  p.append(`${label} record: `);
  const base = `${record.scenario}-${key}`;
  for (const [what, make] of [
    ["JSON", () => save(`${base}.json`, "application/json", JSON.stringify(record))],
    ["CSV", () => save(`${base}.csv`, "text/csv", recordCsv(record))],
  ] as const) {
    const b = document.createElement("button");
    b.type = "button";
    b.textContent = what;
    b.dataset.testid = `cbf-download-${key}-${what.toLowerCase()}`;
    b.addEventListener("click", make);
    p.append(b, " ");
  }
  return p;
}
