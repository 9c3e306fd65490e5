// Preparing a Kelvin object on the server: from a built-in asset or an uploaded file, as a job
// whose progress comes over /ws ("job" and "object" messages; polled as well, so a message sent
// before we listened is never waited for). The job can be cancelled.
import { api, ApiError } from "../../core/api";
import { socket, type TextMessage } from "../../core/socket";
import type { Estimate, Job, KelvinObject, KelvinStats } from "../../core/wire";

export type ObjectStats = KelvinStats;
export type ObjectStatus = KelvinObject;
type JobStatus = Job;

export type Source = { asset: string } | { upload: string; name: string };

export const uploadFormats = ["stl", "obj", "ply", "glb", "off"] as const;

/** Uploads a mesh file; the server imports it with assimp and refuses bad meshes with a message. */
export async function uploadMesh(file: File): Promise<{ upload: string; n_vertices: number; n_faces: number }> {
  const ext = file.name.split(".").pop()?.toLowerCase() ?? "";
  if (!(uploadFormats as readonly string[]).includes(ext))
    throw new ApiError(400, "bad_format", `${file.name}: the file must end in .${uploadFormats.join(", .")}`, "file");
  return api.upload(`/api/kelvin/uploads?format=${ext}`, await file.arrayBuffer());
}

/** POST /api/kelvin/estimate: the server's own vertex estimate and budget for these inputs. */
export type { Estimate };

export function sourceBody(source: Source, lx: number): Record<string, unknown> {
  return "asset" in source ? { asset: source.asset, lx } : { upload: source.upload, lx };
}

export function estimate(source: Source, lx: number): Promise<Estimate> {
  return api.post<Estimate>("/api/kelvin/estimate", sourceBody(source, lx) as never);
}

/** What the panel says before preparing: the expected size and time against the budget. */
export function estimateText(e: Estimate): string {
  const n = e.vertex_estimate.toLocaleString("en");
  const time = e.seconds_estimate === null ? "time unknown until a preparation has run on this server" : `≈ ${e.seconds_estimate < 10 ? e.seconds_estimate.toFixed(1) : Math.round(e.seconds_estimate)} s`;
  return `expected ≈ ${n} field vertices of this server's budget of ${e.max_vertex_estimate.toLocaleString("en")} · ${time}`;
}

export interface PrepareCallbacks {
  progress(stage: string, fraction: number | undefined, cancel: () => void): void;
  /** The object's id, as soon as the server has accepted the job (frames may follow before ready). */
  created(id: string): void;
}

export class ObjectJob {
  private cancelled = false;
  private stopped = false;
  private jobId: string | null = null;
  private objectId: string | null = null;

  /** Creates the object and resolves when it is ready (rejects on failure or cancel). */
  async prepare(source: Source, lx: number, extra: Record<string, unknown>, cb: PrepareCallbacks): Promise<ObjectStatus> {
    const cancel = () => void this.cancel();
    const body: Record<string, unknown> = { ...extra, ...sourceBody(source, lx) };
    let settle: ((s: ObjectStatus) => void) | null = null;
    const done = new Promise<ObjectStatus>((r) => (settle = r));
    const offs = [
      socket.on("job", (m: TextMessage) => {
        const j = m.job as JobStatus | undefined;
        if (j && j.id === this.jobId && j.state === "running") cb.progress(j.stage ?? "", j.fraction, cancel);
      }),
      socket.on("object", (m: TextMessage) => {
        const o = m.object as ObjectStatus | undefined;
        if (o && o.id === this.objectId && o.state !== "preparing") settle?.(o);
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
          if (o && o.state !== "preparing") return o;
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
