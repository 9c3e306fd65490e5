// The CBF API's shapes as the view reads them (see /api/openapi.json, tag cbf). Units: metres,
// radians, seconds; quaternions [w, x, y, z]; positions in the world frame (= robot base).
import type { ShapeJson } from "../../core/shapes";
import type { CbfFrames, Job } from "../../core/wire";

export const METRICS = ["gap", "euclidean"] as const;
export type Metric = (typeof METRICS)[number];
export const METRIC_NAMES: Record<Metric, string> = { gap: "GAP", euclidean: "Euclidean" };

export interface PoseJson {
  position: [number, number, number];
  quaternion?: [number, number, number, number];
}

/** A GAP shape as the server describes it (pose optional: robot primitives carry it separately). */
export type { ShapeJson };

export interface CbfRobot {
  name: string;
  dof: number;
  links: string[];
  /** URDF joints, parents first; q = −1 for a fixed joint. */
  joints: Array<{ name: string; parent: number; child: number; q: number; origin: PoseJson; axis: [number, number, number] }>;
  joint_names: string[];
  q_min: number[];
  q_max: number[];
  velocity_max: number[];
  end_effector: { link: number };
  primitives: Array<{ name: string; link: number; shape: ShapeJson; pose: PoseJson }>;
  self_pairs: Array<[number, number]>;
}

export interface CbfScenario {
  name?: string;
  /** assets/robots/NAME.urdf; "panda" when absent. */
  robot?: string;
  obstacles: Array<{ name?: string; shape: ShapeJson }>;
  target: PoseJson;
  q0: number[];
  dt: number;
  duration: number;
  [key: string]: unknown;
}

export interface CbfLimits {
  max_steps: number;
  max_duration: number;
  max_pair_steps: number;
  max_batch_steps: number;
  max_frames_per_request: number;
  kept_per_session: number;
}

export interface PairInfo {
  name: string;
  a: number;
  b: number;
  self: boolean;
}

export type RolloutState = "queued" | "running" | "finished" | "cancelled" | "failed";

export interface CbfRolloutStatus {
  id: string;
  state: RolloutState;
  scenario: string;
  metric: Metric;
  dt: number;
  steps_total: number;
  steps_done: number;
  pairs: PairInfo[];
  obstacles: CbfScenario["obstacles"];
  target: PoseJson;
  summary?: { reached: boolean; final_task_error: number; min_distance: number | null; infeasible_steps: number; cancelled: boolean };
  job?: JobJson;
}

export type JobJson = Job;
export type CbfFramesMessage = CbfFrames;
export type CbfFrame = CbfFrames["frames"][number];

export interface CbfTiming {
  kinematics_us_mean: number;
  step_us_mean: number;
  distance_us_mean: number;
  qp_us_mean: number;
  audit_us_mean: number;
  wall_s: number;
}

/** The record (GET .../record), requested without per-pair arrays (the frames carry those). */
export interface CbfRecord {
  scenario: string;
  metric: Metric;
  dt: number;
  steps: number;
  pairs: string[];
  t: number[];
  q?: number[][];
  u: number[][];
  task_error: number[];
  min_distance: Array<number | null>;
  infeasible_steps: number[];
  smoothness: { total_variation: number[]; max_rate: number[] };
  timing: CbfTiming;
  summary: {
    reached: boolean;
    final_task_error: number;
    min_distance: number | null;
    cancelled: boolean;
    cold_solves?: number;
    q_final: number[];
    final?: CbfFinalState;
  };
}

/** One QP row active at the rollout's final state (a pair's distance row or a joint limit). */
export interface CbfActiveRow {
  name: string;
  kind: "pair" | "joint_limit";
  distance: number;
  margin: number;
  clearance: number | null;
  converged_distance: number | null;
  multiplier: number;
}

/** Where a rollout ends and which constraints hold it there (summary.final of the record). */
export interface CbfFinalState {
  ee_position: number[];
  position_error: number;
  min_clearance: number | null;
  closest_pair: string;
  active: CbfActiveRow[];
}

/** POST /api/cbf/feasibility: the best clearance reachable at the exact target pose. */
export interface CbfFeasibility {
  scenario: string;
  reachable: boolean;
  q?: number[];
  clearance?: number;
  limiting_pair?: string;
  gap_distance?: number;
  gap_limiting_pair?: string;
  margins?: { euclidean: number; gap: number };
  euclidean_feasible?: boolean;
  gap_feasible?: boolean;
}
