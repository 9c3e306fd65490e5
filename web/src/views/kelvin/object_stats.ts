// What the panel's statistics table and the status line say about the prepared object: its
// field mesh, how it was prepared (computed, cache, shared) and how long that took.
import type { ObjectStats } from "./object_source";

const fixed = (x: unknown, d = 3) => (typeof x === "number" ? x.toFixed(d) : "–");

/** `estimate`: the text the panel showed before preparing (the same words here). */
export function statsRows(name: string, lx: number, st: ObjectStats, inputVertices: number | undefined, prepareMs: number | undefined, estimate = ""): Array<[string, string]> {
  return [
    ["object", `${name}, l_x = ${lx}`],
    ["input surface", `${inputVertices ?? "–"} vertices`],
    ["n_verts / n_tets", `${st.n_verts ?? "–"} / ${st.n_tets ?? "–"}`],
    ["sizing", typeof st.grading !== "number" ? "–" : st.grading > 0 ? `graded, g = ${st.grading}` : "eq. 23 (the paper's)"],
    ["size", `${fixed(st.size_mb, 1)} MB`],
    ["strokes", typeof st.response_mb !== "number" ? "–" : st.response_mb > 0 ? `by the boundary response (${fixed(st.response_mb, 0)} MB)` : "solved with the factor"],
    ["t_mesh / t_build / t_decomp", `${fixed(st.t_mesh)} / ${fixed(st.t_build)} / ${fixed(st.t_decomp)} s`],
    ["cache", st.cache_hit ? `hit (load ${fixed(st.t_load)} s)` : st.shared ? "shared in memory" : "computed"],
    ["prepared in", `${fixed((prepareMs ?? NaN) / 1000, 2)} s (this page), ${fixed(st.t_prepare, 2)} s (server)`],
    ...(estimate ? [["estimate", estimate] as [string, string]] : []),
  ];
}

export function statusLine(name: string, st: ObjectStats): string {
  return `${name} · ${st.n_verts ?? "?"} field vertices · drag on the surface paints σ, elsewhere orbits (b: brush off)`;
}
