// One rollout on the server, as the view follows it: POST, then frames over /ws ("cbf_frames",
// possibly before the POST answer names the id — they are held until claimed), job progress,
// the end (final job message or a slow poll, whichever comes first), holes filled from
// GET .../frames, a replay after a reconnect, and the record (smoothness, timing) at the end.
// With Kelvin fields the job prepares them first (its stages: Kelvin's, then "rollout"), and once
// frames come the objects and iso-surfaces are fetched once (GET .../fields).
import { api, ApiError } from "../../core/api";
import { socket, type TextMessage } from "../../core/socket";
import { FrameStore } from "./frames";
import { specFieldParams, specGapParams, type RolloutSpec } from "./specs";
import type { PostResponse } from "../../core/wire";
import type { CbfFieldGeometry, CbfFramesMessage, CbfRecord, CbfRolloutStatus, JobJson, Metric, RolloutState } from "./types";

/** Frames whose rollout id the page does not know yet (the POST answer is still on its way). */
const unclaimed = new Map<string, CbfFramesMessage[]>();
const owners = new Map<string, Rollout>();
let routing: (() => void) | null = null;

function route(m: TextMessage): void {
  const msg = m as unknown as CbfFramesMessage;
  if (typeof msg.rollout !== "string" || !Array.isArray(msg.frames)) return;
  const arrived = performance.now();
  const owner = owners.get(msg.rollout);
  if (owner) {
    owner.receive(msg, arrived, "ws");
    return;
  }
  const list = unclaimed.get(msg.rollout) ?? [];
  list.push(msg);
  unclaimed.set(msg.rollout, list);
  if (unclaimed.size > 8) unclaimed.delete(unclaimed.keys().next().value!); // someone else's, long gone
}

/** The view stops listening when it unmounts (not per rollout: one may be awaiting its id). */
export function stopRouting(): void {
  routing?.();
  unclaimed.clear();
}

function startRouting(): void {
  if (routing) return;
  const off = socket.on("cbf_frames", route);
  routing = () => {
    off();
    routing = null;
  };
}

export interface RolloutRequest {
  scenario: string | Record<string, unknown>;
  /** Its metric and GAP distance (gap.mode as_published and its stopping rule). */
  spec: RolloutSpec;
  duration: number;
  /** The scenario's Kelvin fields (params.fields of a σ = 0 run has one entry per field). */
  fieldCount: number;
}

/** What the page needs of the robot to keep frames: its primitive and joint counts. */
export interface RobotSize {
  primitives: number;
  dof: number;
}

export interface RolloutEvents {
  /** New frames stored (arrival time of the message that brought them). */
  frames(r: Rollout, added: number, arrived: number): void;
  progress(r: Rollout): void;
  ended(r: Rollout): void;
  error(r: Rollout, e: unknown): void;
  /** The Kelvin objects arrived (r.geometry), or could not be fetched (r.geometryError). */
  fields(r: Rollout): void;
}

export class Rollout {
  id: string | null = null;
  status: CbfRolloutStatus | null = null;
  store: FrameStore | null = null;
  state: RolloutState = "queued";
  stepsTotal = 0;
  stepsDone = 0;
  record: CbfRecord | null = null;
  error: ApiError | Error | null = null;
  /** The job's stage and fraction (Kelvin's stages while the fields are prepared, then "rollout"). */
  stage = "";
  stageFraction = 0;
  /** The Kelvin objects and iso-surfaces (GET .../fields), once fetched. */
  geometry: CbfFieldGeometry | null = null;
  geometryError: unknown = null;
  /** The iso-levels to fetch the shells at (levelsQuery's form; "": the server's 0 and δ), and
   *  those the geometry has. */
  fieldLevels = "";
  geometryLevels = "";
  /** The server refused fieldLevels when the fields were first fetched (the default ones shown). */
  levelsError: ApiError | null = null;
  private geometryAsked = false;
  /** Non-empty "cbf_frames" messages taken from the WebSocket, and pages fetched over REST. */
  wsMessages = 0;
  restPages = 0;
  private disposed = false;
  private offs: Array<() => void> = [];
  private pollTimer = 0;
  private ending = false;
  private cancelRequested = false;
  /** Wall time from the POST to the last step stored, and to the end (ms). */
  readonly times = { posted: 0, firstFrame: 0, lastFrame: 0, ended: 0 };

  constructor(
    readonly request: RolloutRequest,
    readonly robot: RobotSize,
    private readonly events: RolloutEvents,
  ) {}

  get metric(): Metric {
    return this.request.spec.metric;
  }
  get spec(): RolloutSpec {
    return this.request.spec;
  }
  get running(): boolean {
    return this.state === "queued" || this.state === "running";
  }

  /** POSTs the rollout; resolves once the server accepted it (frames then stream in). */
  async start(): Promise<void> {
    startRouting();
    this.offs.push(
      socket.on("job", (m) => this.onJob(m.job as JobJson | undefined)),
      socket.onOpen(() => this.replay()),
    );
    this.times.posted = performance.now();
    const gap = specGapParams(this.spec);
    const body = {
      scenario: this.request.scenario,
      metric: this.metric,
      params: {
        duration: this.request.duration,
        record_pairs: false,
        audit: true,
        ...(gap ? { gap } : {}),
        ...specFieldParams(this.spec, this.request.fieldCount),
      },
      stream: { batch_steps: 25, pairs: true, poses: true },
    };
    let r: { rollout: CbfRolloutStatus; job: JobJson };
    try {
      r = await api.post<PostResponse<"/api/cbf/rollouts">>("/api/cbf/rollouts", body);
    } catch (e) {
      this.state = "failed";
      this.error = e instanceof Error ? e : new Error(String(e));
      this.dispose();
      throw e;
    }
    if (this.disposed) {
      void api.post(`/api/jobs/${r.rollout.id}/cancel`).catch(() => undefined);
      return;
    }
    this.id = r.rollout.id;
    this.status = r.rollout;
    this.state = r.rollout.state;
    this.stepsTotal = r.rollout.steps_total;
    const kelvin = r.rollout.kelvin;
    this.store = new FrameStore(r.rollout.pairs.length, this.robot.primitives, r.rollout.dt, this.robot.dof, kelvin?.fields.length ?? 0, kelvin?.control_points.length ?? 0);
    owners.set(this.id, this);
    const early = unclaimed.get(this.id) ?? [];
    unclaimed.delete(this.id);
    early.forEach((m) => this.receive(m, performance.now(), "ws"));
    if (this.cancelRequested) void this.cancel();
    this.poll();
  }

  receive(m: CbfFramesMessage, arrived: number, via: "ws" | "rest"): void {
    if (!this.store || this.disposed) return;
    if (m.frames.length > 0) {
      if (via === "ws") this.wsMessages++;
      else this.restPages++;
    }
    this.stepsDone = Math.max(this.stepsDone, m.steps_done);
    this.stepsTotal = m.steps_total;
    const added = this.store.add(m.frames);
    if (added > 0 && this.store.fieldCount > 0) void this.loadFields();
    if (added > 0) {
      if (!this.times.firstFrame) this.times.firstFrame = arrived;
      this.times.lastFrame = arrived;
      this.events.frames(this, added, arrived);
    }
    this.events.progress(this);
  }

  async cancel(): Promise<void> {
    this.cancelRequested = true;
    if (!this.id || !this.running) return;
    await api.post(`/api/jobs/${this.id}/cancel`).catch(() => undefined);
  }

  /** GET .../fields with these iso-levels (levelsQuery's "0.1,0.3"; "": the server's 0 and δ). */
  fetchFields(levels: string): Promise<CbfFieldGeometry> {
    const q = levels ? `?levels=${encodeURIComponent(levels)}` : "";
    return api.msgpack<CbfFieldGeometry>("GET", `/api/cbf/rollouts/${this.id}/fields${q}`);
  }

  /** The objects and iso-surfaces of the fields, once (they are prepared when frames come), at
   *  fieldLevels (again if they changed meanwhile). Levels the server refuses are reported
   *  (levelsError) and its default ones drawn. */
  private async loadFields(): Promise<void> {
    if (this.geometryAsked || !this.id) return;
    this.geometryAsked = true;
    for (let guard = 0; guard < 4 && !this.disposed; guard++) {
      const levels = this.fieldLevels;
      try {
        this.geometry = await this.fetchFields(levels);
        this.geometryLevels = levels;
        this.geometryError = null;
      } catch (e) {
        if (levels && e instanceof ApiError && e.field === "levels") {
          this.levelsError = e;
          this.fieldLevels = "";
          continue;
        }
        this.geometryError = e;
      }
      if (this.fieldLevels === levels) break;
    }
    if (!this.disposed) this.events.fields(this);
  }

  private onJob(j: JobJson | undefined): void {
    if (!j || j.id !== this.id || this.disposed) return;
    if (j.stage !== undefined) {
      this.stage = j.stage;
      this.stageFraction = j.fraction ?? 0;
    }
    if (j.state === "running" || j.state === "queued") {
      if (this.state === "queued") this.state = "running";
      this.events.progress(this);
      return;
    }
    if (j.state === "failed" && j.error) this.error = new ApiError(422, j.error.code ?? "job_failed", j.error.message ?? "rollout failed", j.error.field || undefined);
    void this.finish();
  }

  /** A slow poll as well: a final job message sent while the socket was down is never waited for. */
  private poll(): void {
    clearTimeout(this.pollTimer);
    this.pollTimer = window.setTimeout(async () => {
      if (this.disposed || !this.id || this.ending) return;
      let s: CbfRolloutStatus | null = null;
      try {
        s = await api.get<CbfRolloutStatus>(`/api/cbf/rollouts/${this.id}`);
      } catch (e) {
        if (e instanceof ApiError && e.status === 404) {
          // The server restarted (or forgot it): what arrived stays playable, nothing more comes.
          this.ending = true;
          this.state = "failed";
          this.error = new ApiError(404, e.code, `the server no longer has this rollout (restarted?); ${this.store?.contiguous ?? 0} steps were received`);
          this.times.ended = performance.now();
          if (!this.disposed) this.events.ended(this);
          return;
        }
      }
      if (s && s.state !== "queued" && s.state !== "running") void this.finish();
      else this.poll();
    }, 1000);
  }

  /** The job ended: fill holes in the frames, fetch the record. */
  private async finish(): Promise<void> {
    if (this.ending || !this.id) return;
    this.ending = true;
    clearTimeout(this.pollTimer);
    const id = this.id;
    try {
      const s = await api.get<CbfRolloutStatus>(`/api/cbf/rollouts/${id}`);
      this.status = s;
      this.stepsDone = s.steps_done;
      await this.drainStream(s.steps_done);
      await this.fillHoles(s.steps_done);
      if (s.state === "failed") {
        this.state = "failed";
        this.error ??= new Error("the rollout failed on the server");
      } else if (s.state === "cancelled" && s.steps_done === 0) {
        this.state = "cancelled"; // before its first step (while its fields were prepared): no record
      } else {
        this.record = await api.get<CbfRecord>(`/api/cbf/rollouts/${id}/record`);
        this.state = s.state;
      }
    } catch (e) {
      this.state = "failed";
      this.error = e instanceof Error ? e : new Error(String(e));
      this.events.error(this, e);
    }
    this.times.ended = performance.now();
    if (!this.disposed) this.events.ended(this);
  }

  /** The end can be seen (poll) while frames are still on their way over the socket: wait for
   *  them as long as they keep coming, so REST only fetches what the socket really lost. */
  private async drainStream(done: number): Promise<void> {
    const store = this.store!;
    let last = store.received,
      since = performance.now();
    while (!this.disposed && store.contiguous < done && socket.state === "open" && performance.now() - since < 1000) {
      await new Promise((r) => setTimeout(r, 50));
      if (store.received !== last) {
        last = store.received;
        since = performance.now();
      }
    }
  }

  private async fillHoles(done: number): Promise<void> {
    const store = this.store!;
    for (let guard = 0; guard < 1000; guard++) {
      const from = store.firstMissing(done);
      if (from < 0) return;
      const m = await api.get<CbfFramesMessage>(`/api/cbf/rollouts/${this.id}/frames?from=${from}&count=500`);
      if (m.frames.length === 0) return;
      this.receive(m, performance.now(), "rest");
    }
  }

  private replay(): void {
    if (!this.id || !this.store || this.disposed) return;
    socket.send({ type: "cbf_replay", rollout: this.id, from: this.store.contiguous });
  }

  dispose(): void {
    this.disposed = true;
    clearTimeout(this.pollTimer);
    this.offs.forEach((f) => f());
    this.offs = [];
    if (this.id) owners.delete(this.id);
  }
}
