// Preparing a Kelvin object on the server: from a built-in asset or an uploaded file, as a job
// whose progress comes over /ws ("job" and "object" messages; polled as well, so a message sent
// before we listened is never waited for). The job can be cancelled.
import { api, ApiError } from "../../core/api";
import { socket, type TextMessage } from "../../core/socket";
import type { MeshFrame } from "../../core/meshframe";
import type { Estimate, Job, KelvinObject, KelvinStats, RepairReport, Schemas } from "../../core/wire";
import type { Reshape } from "./kelvin_state";

export type ObjectStats = KelvinStats;
export type ObjectStatus = KelvinObject;
type JobStatus = Job;
/** What "fix" changed (counts per step) or what "wrap" made (α, offset, one-sided distances). */
export type { RepairReport };

export type Source = { asset: string } | { upload: string; name: string };

export const uploadFormats = ["stl", "obj", "ply", "glb", "off"] as const;

/** The upload's answer: counts, its digest, the box in metres (after the unit) and the l_x range that fits. */
export type Uploaded = Schemas["KelvinUpload"];
/** Where an upload is not a closed 2-manifold (GET /api/kelvin/uploads/{id}/defects). */
export type Defects = Schemas["KelvinDefects"];

/** Uploads a mesh file in `unit`; the server imports it and refuses bad meshes with a message.
 *  With `digest` (a link's), the server refuses a file whose mesh is another one. */
export async function uploadMesh(file: File, unit = "m", digest?: string): Promise<Uploaded> {
  const ext = file.name.split(".").pop()?.toLowerCase() ?? "";
  if (!(uploadFormats as readonly string[]).includes(ext)) throw new ApiError(400, "bad_format", `${file.name}: the file must end in .${uploadFormats.join(", .")}`, "file");
  const expect = digest ? `&digest=${digest}` : "";
  return api.upload(`/api/kelvin/uploads?format=${ext}&unit=${encodeURIComponent(unit)}${expect}`, await file.arrayBuffer());
}

/** The mesh with this digest as an upload of this session, if the server holds it (404 otherwise). */
export function reuseUpload(digest: string): Promise<Uploaded> {
  return api.post<Uploaded>("/api/kelvin/uploads/reuse", { digest });
}

/** An upload's mesh (the file's vertices in its order, metres) and where it is not closed. */
export async function uploadGeometry(id: string): Promise<{ frame: MeshFrame; defects: Defects }> {
  const [frame, defects] = await Promise.all([api.get<MeshFrame>(`/api/kelvin/uploads/${id}/surface`), api.get<Defects>(`/api/kelvin/uploads/${id}/defects`)]);
  return { frame, defects };
}

const metres = (x: number) => `${Number(x.toPrecision(3))} m`;

/** The upload dialog's first line: what the server read, in metres, and the l_x it accepts. */
export function uploadText(name: string, u: Uploaded): string {
  const parts = [`${name}: ${u.n_vertices.toLocaleString("en")} vertices, ${u.n_faces.toLocaleString("en")} triangles`];
  const b = u.bounding_box;
  const lo = b?.min,
    hi = b?.max;
  if (lo && hi) parts.push(`size ${hi.map((x, k) => Number((x - lo[k]).toPrecision(3))).join(" × ")} m (file unit ${u.unit ?? "scaled"})`);
  if (u.lx_range?.min !== undefined && u.lx_range.max !== undefined) parts.push(`l_x from ${metres(u.lx_range.min)} to ${metres(u.lx_range.max)}`);
  else if (b) parts.push("no l_x fits this server's budget");
  return parts.join(" · ");
}

/** The repair's report as the server gives it. */
export function repairText(r: RepairReport): string {
  const size = `${r.n_vertices.toLocaleString("en")} vertices, ${r.n_faces.toLocaleString("en")} triangles`;
  const h = r.hausdorff;
  if (r.kind === "wrap" && h?.input_to_wrap !== undefined && h.wrap_to_input !== undefined)
    return `wrapped at α ${metres(r.alpha ?? 0)}, offset ${metres(r.offset ?? 0)}: ${size}; farthest input → wrap ${metres(h.input_to_wrap)}, wrap → input ${metres(h.wrap_to_input)}`;
  const steps = Object.entries(r.steps ?? {})
    .filter(([, n]) => n > 0)
    .map(([k, n]) => `${k.replace(/_/g, " ")} ${n}`);
  const moved =
    h?.input_to_fixed !== undefined && h.fixed_to_input !== undefined ? `; farthest input → fixed ${metres(h.input_to_fixed)}, fixed → input ${metres(h.fixed_to_input)}` : "";
  return `fixed (${steps.length ? steps.join(", ") : "nothing to change"}): ${size}${moved}`;
}

/** POST /api/kelvin/estimate: the server's own vertex estimate and budget for these inputs. */
export type { Estimate };

/** The request's reshaping keys; options left at 0 are the server's defaults (not sent). */
export function reshapeBody(r: Reshape): Record<string, unknown> {
  const body: Record<string, unknown> = {};
  if (r.repair !== "none") body.repair = r.repair;
  const options: Record<string, number> = {};
  if (r.repair === "fix" && r.holeEdges > 0) options.max_hole_edges = r.holeEdges;
  if (r.repair === "wrap" && r.alpha > 0) options.alpha = r.alpha;
  if (r.repair === "wrap" && r.offset > 0) options.offset = r.offset;
  if (Object.keys(options).length) body.repair_options = options;
  if (r.simplify > 0) body.simplify = { faces: r.simplify };
  if (r.components !== "all") body.components = r.components;
  return body;
}

const noReshape: Reshape = { repair: "none", holeEdges: 0, alpha: 0, offset: 0, simplify: 0, components: "all" };

export function sourceBody(source: Source, lx: number, reshape: Reshape = noReshape): Record<string, unknown> {
  const body: Record<string, unknown> = "asset" in source ? { asset: source.asset, lx } : { upload: source.upload, lx };
  return { ...body, ...reshapeBody(reshape) };
}

export function estimate(source: Source, lx: number, reshape: Reshape = noReshape): Promise<Estimate> {
  return api.post<Estimate>("/api/kelvin/estimate", sourceBody(source, lx, reshape) as never);
}

/** The prediction's numbers, from POST /api/kelvin/estimate or an object's `estimate` (made by its
 *  job once a repair has made the surface). */
export type Prediction = Pick<Estimate, "vertices_predicted" | "grading" | "seconds_estimate" | "seconds_per_vertex">;

const seconds = (s: number) => (s < 10 ? s.toFixed(1) : String(Math.round(s)));

/** What the panel says before (and while) preparing: the server's predicted field vertices for the
 *  sizing it will choose, and the time they take at this server's seconds per vertex. `pending`:
 *  what makes the surface when the server could not predict before it exists (a fix or wrap). */
export function estimateText(e: Prediction & { problem?: Estimate["problem"] }, pending = "the repair"): string {
  if (e.problem) return `not prepared: ${e.problem.message}`;
  if (e.vertices_predicted === null || e.seconds_estimate === null) return `field vertices: predicted once ${pending} has made the surface`;
  const sizing = e.grading === null ? "" : e.grading > 0 ? " (graded sizing)" : " (eq. 23 sizing)";
  const r = e.seconds_per_vertex;
  const rate = `${(r.value * 1000).toPrecision(2)} ms per vertex, ${r.source === "measured" ? `measured here over ${r.preparations} preparation${r.preparations === 1 ? "" : "s"}` : "this server's default until it has prepared one"}`;
  return `expected ≈ ${e.vertices_predicted.toLocaleString("en")} field vertices${sizing}, ≈ ${seconds(e.seconds_estimate)} s at ${rate}`;
}

/** What the chosen reshaping will do, with the server's prediction for a wrap. */
export function repairEstimateText(e: Estimate, r: Reshape): string {
  const parts: string[] = [];
  if (r.components === "largest") parts.push("keeps the piece enclosing the largest volume");
  if (r.simplify > 0) parts.push(`simplifies to ${r.simplify.toLocaleString("en")} faces`);
  if (r.repair === "fix") parts.push(r.holeEdges > 0 ? `fix fills holes of up to ${r.holeEdges.toLocaleString("en")} edges` : "fix fills no hole (hole size 0)");
  const w = e.repair_estimate;
  if (r.repair === "wrap" && w?.alpha !== undefined && w.offset !== undefined) {
    const s = w.seconds ?? 0;
    parts.push(
      `wrap at α ${metres(w.alpha)}, offset ${metres(w.offset)}: ≈ ${Math.round(w.faces ?? 0).toLocaleString("en")} faces, ${Math.round(w.megabytes ?? 0)} MB, ${s < 10 ? s.toFixed(1) : Math.round(s)} s (the server's prediction)`,
    );
  }
  return parts.length ? parts.join("; ") : "no repair chosen: the mesh is prepared as it is";
}

export interface PrepareCallbacks {
  progress(stage: string, fraction: number | undefined, cancel: () => void): void;
  /** The object's id, as soon as the server has accepted the job (frames may follow before ready). */
  created(id: string): void;
  /** A repair request's surface is made (before the field is prepared on it): its report. */
  repaired?(status: ObjectStatus): void;
  /** The job's prediction, made on the surface it prepares (after a repair), before it prepares. */
  estimated?(status: ObjectStatus): void;
}

const working = (s: ObjectStatus["state"]) => s === "repairing" || s === "preparing";

export class ObjectJob {
  private cancelled = false;
  private stopped = false;
  private jobId: string | null = null;
  private objectId: string | null = null;

  /** Creates the object and resolves when it is ready (rejects on failure or cancel). */
  async prepare(source: Source, lx: number, extra: Record<string, unknown>, cb: PrepareCallbacks, reshape: Reshape = noReshape): Promise<ObjectStatus> {
    const cancel = () => void this.cancel();
    const body: Record<string, unknown> = { ...extra, ...sourceBody(source, lx, reshape) };
    let repairSeen = false;
    let estimateSeen = false;
    const seen = (o: ObjectStatus) => {
      if (!repairSeen && o.repair_report && cb.repaired) {
        repairSeen = true;
        cb.repaired(o);
      }
      if (!estimateSeen && o.estimate && cb.estimated) {
        estimateSeen = true;
        cb.estimated(o);
      }
    };
    let settle: ((s: ObjectStatus) => void) | null = null;
    const done = new Promise<ObjectStatus>((r) => (settle = r));
    const offs = [
      socket.on("job", (m: TextMessage) => {
        const j = m.job as JobStatus | undefined;
        if (j && j.id === this.jobId && j.state === "running") cb.progress(j.stage ?? "", j.fraction, cancel);
      }),
      socket.on("object", (m: TextMessage) => {
        const o = m.object as ObjectStatus | undefined;
        if (o && o.id === this.objectId) {
          seen(o);
          if (!working(o.state)) settle?.(o);
        }
      }),
    ];
    cb.progress("queued", undefined, cancel);
    try {
      const created = await api.post<{ object: ObjectStatus; job: JobStatus }>("/api/kelvin/objects", body);
      this.objectId = created.object.id;
      this.jobId = created.job.id;
      cb.created(this.objectId);
      if (this.cancelled) await this.cancel();
      // Poll as well: the final "object" message may have been sent before we knew the id.
      const poll = async () => {
        while (!this.stopped) {
          await new Promise((r) => setTimeout(r, 400));
          const o = await api.get<ObjectStatus>(`/api/kelvin/objects/${this.objectId}`).catch(() => null);
          if (o) seen(o);
          if (o && !working(o.state)) return o;
          const j = await api.get<JobStatus>(`/api/jobs/${this.jobId}`).catch(() => null);
          if (j?.state === "running") cb.progress(j.stage ?? "", j.fraction, cancel);
        }
        return null;
      };
      const status = await Promise.race([done, poll().then((o) => o ?? done)]);
      if (status.state === "ready") return status;
      if (status.state === "cancelled" || this.cancelled) throw new ApiError(0, "cancelled", "preparation cancelled");
      const e = status.error;
      throw new ApiError(422, e?.code ?? "job_failed", e?.message ?? "preparation failed", e?.field || undefined);
    } finally {
      this.stopped = true; // ends the poll loop
      offs.forEach((f) => f());
    }
  }

  async cancel(): Promise<void> {
    this.cancelled = true;
    if (this.jobId && !this.stopped) await api.post(`/api/jobs/${this.jobId}/cancel`).catch(() => undefined);
  }
}
