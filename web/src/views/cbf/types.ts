// The CBF API's shapes (tag cbf of /api/openapi.json), generated from the OpenAPI document
// (core/wire.gen.ts): a server change the view does not follow fails tsc. Units: metres, radians,
// seconds; quaternions [w, x, y, z]; positions in the world frame (= robot base).
import type { MeshFrame } from "../../core/meshframe";
import type { GetResponse, Schemas } from "../../core/wire";

export type Metric = Schemas["CbfMetric"];
export const METRICS = ["gap", "euclidean"] as const satisfies readonly Metric[];
export const METRIC_NAMES: Record<Metric, string> = { gap: "GAP", euclidean: "Euclidean" };

export type PoseJson = Schemas["CbfPose"];
export type CbfRobot = Schemas["CbfRobot"];
export type CbfScenario = Schemas["CbfScenario"];
export type CbfLimits = GetResponse<"/api/cbf/scenarios">["limits"];
export type PairInfo = Schemas["CbfPair"];
export type CbfRolloutStatus = Schemas["CbfRollout"];
export type RolloutState = CbfRolloutStatus["state"];
export type JobJson = Schemas["Job"];
export type CbfFramesMessage = Schemas["CbfFrames"];
export type CbfFrame = CbfFramesMessage["frames"][number];
/** The record (GET .../record); the view requests it without per-pair arrays (the frames carry those). */
export type CbfRecord = Schemas["CbfRecord"];
export type CbfTiming = CbfRecord["timing"];
/** Where a rollout ends and which constraints hold it there (summary.final of the record). */
export type CbfFinalState = Schemas["CbfRecordSummary"]["final"];
/** One QP row active at the rollout's final state (a pair's distance row or a joint limit). */
export type CbfActiveRow = CbfFinalState["active"][number];
/** POST /api/cbf/feasibility: the best clearance reachable at the exact target pose. */
export type CbfFeasibility = Schemas["CbfFeasibility"];
export type CbfSweep = Schemas["CbfSweep"];
export type CbfSweepEntry = Schemas["CbfSweepEntry"];

/** One Kelvin field at one step of a frame: h at every control point, the closest surface point. */
export type CbfFieldStep = Schemas["CbfFieldStep"];
/** A rollout's fields as the server accepted it: state, control points, objects (δ, pose). */
export type CbfRolloutKelvin = NonNullable<CbfRolloutStatus["kelvin"]>;
export type CbfControlPoint = CbfRolloutKelvin["control_points"][number];
/** The record's Kelvin part (per field, columns over the steps; safety distances). */
export type CbfRecordKelvin = Schemas["CbfRecordKelvin"];

/** GET .../fields decoded (msgpack; its binary arrays as bytes, read through core/meshframe). */
export interface CbfFieldGeometry {
  type: "cbf_fields";
  rollout: string;
  fields: Array<{
    index: number;
    name: string;
    delta: number;
    pose: PoseJson;
    frame: "object";
    surface: MeshFrame;
    isosurfaces: Array<MeshFrame & { level: number; empty?: boolean; h_min?: number }>;
  }>;
}
