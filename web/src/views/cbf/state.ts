// The view's shareable state (the URL): scenario (a name, or an edited inline scenario), which
// metric(s), duration, the current time and how things are drawn. A link with `run` set re-runs
// the rollout(s) on load and returns to `t`.
import { readColorScale } from "../../core/colorbar";
import type { ColorScale } from "../../core/colormap";
import { num, str } from "../../core/urlstate";
import type { Layout } from "./scene";

export const METRIC_CHOICES = ["both", "gap", "euclidean"] as const;
export type MetricChoice = (typeof METRIC_CHOICES)[number];
export const WITNESS_MODES = ["closest", "all", "none"] as const;
export const SPEEDS = [0.1, 0.25, 0.5, 1, 2, 4, 10] as const;
/** How the GAP rollout computes D (scenario field gap.mode; franka-corridor.md): converged, or as
 * the published package did with its simulation (2e-4 / 300) or real-robot (5e-4 / 20) stopping rule. */
export const GAP_MODES = ["exact", "as_published_sim", "as_published_real"] as const;
export type GapModeChoice = (typeof GAP_MODES)[number];

/** The second rollout of a run, drawn over the first on the same plots and robot (sigma_zero and
 *  hull: the first's metric with σ = 0, or with the objects' hulls; scenarios with Kelvin fields). */
export const COMPARE_CHOICES = ["none", "euclidean", "gap_exact", "gap_as_published_sim", "gap_as_published_real", "sigma_zero", "hull"] as const;
export type CompareChoice = (typeof COMPARE_CHOICES)[number];

/** The request's params.gap for a GAP mode (null: the scenario's own, exact by default). */
export function gapParams(mode: GapModeChoice): Record<string, unknown> | null {
  if (mode === "as_published_sim") return { mode: "as_published", tol: 2e-4, max_iter: 300 };
  if (mode === "as_published_real") return { mode: "as_published", tol: 5e-4, max_iter: 20 };
  return null;
}

export interface CbfState {
  scenario: string;
  /** An edited scenario posted inline (null: the named one). */
  inline: Record<string, unknown> | null;
  metric: MetricChoice;
  gapMode: GapModeChoice;
  /** The rollout compared with the first (metric "both" compares GAP with Euclidean itself). */
  compare: CompareChoice;
  /** Seconds to run; null: the scenario's own duration. */
  duration: number | null;
  t: number;
  speed: number;
  witnesses: (typeof WITNESS_MODES)[number];
  closest: number;
  layout: Layout;
  /** The joint plotted alone (1 … the robot's dof), or 0 = all joints. */
  joint: number;
  run: boolean;
  /** Kelvin fields: what is drawn (the object painted with σ, the shells of h = 0 and δ, the
   *  control points) and σ's colour scale (the Kelvin view's default). */
  fieldObject: boolean;
  fieldShells: boolean;
  fieldPoints: boolean;
  /** The iso-levels of h drawn as shells, as typed (comma-separated numbers; empty: 0 and δ). */
  isoLevels: string;
  sigmaColor: ColorScale;
}

export function defaultState(): CbfState {
  return {
    scenario: "corridor",
    inline: null,
    metric: "both",
    gapMode: "exact",
    compare: "none",
    duration: null,
    t: 0,
    speed: 1,
    witnesses: "closest",
    closest: 4,
    layout: "overlay",
    joint: 0,
    run: false,
    fieldObject: true,
    fieldShells: true,
    fieldPoints: true,
    isoLevels: "",
    sigmaColor: { map: "coolwarm", mode: "symmetric", min: -1, max: 1 },
  };
}

/** The iso-levels as the server's ?levels= takes them ("0.1,0.3"; "": its default, 0 and δ). The
 *  server checks them (finite numbers, at most its max_levels) and names what is wrong. */
export function levelsQuery(text: string): string {
  return text
    .split(/[\s,;]+/)
    .filter((x) => x !== "")
    .join(",");
}

export function parseState(raw: Record<string, unknown>): CbfState {
  const d = defaultState();
  const inline = raw.inline && typeof raw.inline === "object" && !Array.isArray(raw.inline) ? (raw.inline as Record<string, unknown>) : null;
  return {
    scenario: typeof raw.scenario === "string" && /^[A-Za-z0-9_-]{1,64}$/.test(raw.scenario) ? raw.scenario : d.scenario,
    inline,
    metric: str(raw.metric, METRIC_CHOICES, d.metric),
    gapMode: str(raw.gapMode, GAP_MODES, d.gapMode),
    compare: str(raw.compare, COMPARE_CHOICES, d.compare),
    // The server states its own limit; absent: the scenario's own duration.
    duration: typeof raw.duration === "number" ? num(raw.duration, 35, 0.01, 1e6) : null,
    t: num(raw.t, 0, 0, 1e6),
    speed: num(raw.speed, d.speed, 0.01, 100),
    witnesses: str(raw.witnesses, WITNESS_MODES, d.witnesses),
    closest: Math.round(num(raw.closest, d.closest, 1, 1000)),
    layout: str(raw.layout, ["overlay", "side"] as const, d.layout),
    // Clamped to the robot's joints once it is known (the view's setRobot).
    joint: Math.round(num(raw.joint, d.joint, 0, 64)),
    run: raw.run === true,
    fieldObject: raw.fieldObject !== false,
    fieldShells: raw.fieldShells !== false,
    fieldPoints: raw.fieldPoints !== false,
    isoLevels: typeof raw.isoLevels === "string" ? raw.isoLevels.slice(0, 400) : d.isoLevels,
    sigmaColor: readColorScale(raw.sigmaColor, d.sigmaColor),
  };
}

/** What goes in the URL (defaults are left out to keep links short). */
export function stateJson(s: CbfState): Record<string, unknown> {
  const d = defaultState() as unknown as Record<string, unknown>;
  const out: Record<string, unknown> = {};
  for (const [k, v] of Object.entries(s)) {
    if (k === "t") {
      if (s.run) out.t = Math.round(v * 1000) / 1000;
      continue;
    }
    if (JSON.stringify(v) !== JSON.stringify(d[k])) out[k] = v;
  }
  return out;
}
