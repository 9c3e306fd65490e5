// View 2, the semantic distance explorer (issue 5): prepare a Kelvin object (built-in or
// uploaded) with a progress bar, paint σ on its surface, watch iso-surfaces of h pushed by the
// server, slice h on a plane, probe h and ∇h, export iso-surfaces. State lives in the URL.
import * as THREE from "three";
import { api, ApiError } from "../../core/api";
import type { Shortcut } from "../../core/keys";
import { isMeshFrame, type MeshFrame } from "../../core/meshframe";
import { socket, SocketRequestError, type BinaryFrame } from "../../core/socket";
import { showError, toast } from "../../core/toast";
import type { View, ViewHost } from "../../core/view";
import { Viewport } from "../../core/viewport";
import { BrushTool } from "./brush_tool";
import { Coalescer } from "./coalesce";
import { IsoLayers, type IsoFrameInfo } from "./iso_layers";
import { DEFAULT_BASE, defaultLx, readState, writeStateJson, type KelvinState } from "./kelvin_state";
import { ObjectJob, uploadMesh, type ObjectStatus, type Source } from "./object_source";
import { Panel } from "./panel";
import { Probe } from "./probe";
import { composeSigma, evaluateAll, evaluateAt, presets, type Brush, type SigmaBody } from "./sigma";
import { SliceLayer } from "./slice_layer";
import { SurfaceLayer } from "./surface_layer";
import { installHooks, type Timings } from "./test_hooks";
import "./kelvin.css";

/** One σ edit on its way to the screen (performance.now times; ms sums). */
interface EditTrace {
  since: number; // its first mouse event
  sent: number;
  answered: number; // the server acknowledged its version
  arrived: number; // the last of its frames arrived (before decode)
  processed: number; // ... and was made a geometry
  decodeMs: number;
  acceptMs: number;
  serverMs: number; // server: edit received → last frame sent (frame.server_ms.since_edit)
  raf: number; // the animation frame that draws it began
}

/** How long a ready object's surface is awaited on the socket before it is fetched by REST. The
 *  server sends it right after the "ready" message (before any iso-surface); this only covers a
 *  frame that cannot come (the socket closed meanwhile) without fetching ~4 MB twice when it is
 *  merely queued behind other work on the server. */
const SURFACE_SOCKET_WAIT_MS = 10000;

interface Limits {
  max_query_points?: number;
  min_lx?: number;
}

export class KelvinView implements View {
  private host!: ViewHost;
  private viewport: Viewport | null = null;
  private state!: KelvinState;
  private panel: Panel | null = null;
  private iso = new IsoLayers();
  private slice: SliceLayer | null = null;
  private probe: Probe | null = null;
  private brush: BrushTool | null = null;
  private surface: SurfaceLayer | null = null;
  private objectId: string | null = null;
  private pendingId: string | null = null;
  private status: ObjectStatus | null = null;
  private job: ObjectJob | null = null;
  private upload: Source | null = null;
  private ticket = 0;
  private offs: Array<() => void> = [];
  private strokes: number[] = []; // brushes.length at each stroke's start (undo)
  private sigmaVersion = 0;
  private frameLog: IsoFrameInfo[] = [];
  private waiters: Array<{ version: number; resolve: () => void }> = [];
  private unsentSince: number | null = null;
  // σ version → the stages of its way to the screen (performance.now times, see Timings).
  private awaitingDraw = new Map<number, EditTrace>();
  private drawing: Array<[number, EditTrace]> = []; // complete in the frame being rendered
  private inflight: EditTrace | null = null; // the edit sent and not yet acknowledged
  private localPending: number[] = []; // mouse events whose σ colours are not drawn yet
  readonly timings: Timings = { prepareMs: [], strokeToFrameMs: [], strokeToColourMs: [], sliceMs: [] };
  private sigmaSync = new Coalescer<void>(() => this.sendSigma());
  private hoverEvent: PointerEvent | null = null;
  private firstOpen = true;
  private unclaimed: MeshFrame[] = [];
  // The surface frame pushed on the socket for the object being prepared, until load() takes it.
  private socketSurface: MeshFrame | null = null;
  private surfaceWaiter: { id: string; take: (f: MeshFrame) => void; cancel: () => void } | null = null;
  /** Where the shown surface came from: the socket's frame, or REST when that did not come. */
  surfaceSource: "socket" | "rest" | null = null;
  private sliceAtVersion = -1;

  async mount(host: ViewHost, raw: Record<string, unknown>): Promise<void> {
    this.host = host;
    this.state = readState(raw);
    const vp = (this.viewport = new Viewport(host.canvas));
    vp.grid.visible = false;
    vp.scene.add(this.iso.group);
    const [limits, assets] = await Promise.all([
      api.get<Limits>("/api/limits").catch(() => ({}) as Limits),
      api.get<{ assets: string[] }>("/api/kelvin/assets").then((r) => r.assets).catch((e) => (showError(e, "cannot list the built-in objects"), ["cube"])),
    ]);
    if (this.viewport !== vp) return; // unmounted meanwhile
    if (this.state.object === "upload") {
      toast("the shared link used an uploaded mesh, which lives only in its session: showing the cube", "info", 6000);
      this.state.object = "cube";
      this.state.lx = defaultLx.cube;
    }
    this.slice = new SliceLayer(limits.max_query_points ?? 10000);
    this.slice.onError = (e) => showError(e, "slice");
    this.slice.onSampled = () => {
      this.timings.sliceMs.push(this.slice!.lastSampleMs);
      vp.invalidate();
    };
    vp.scene.add(this.slice.plane);
    this.probe = new Probe(host.canvas);
    this.probe.onChange = () => vp.invalidate();
    vp.scene.add(this.probe.arrow, this.probe.marker);
    this.brush = new BrushTool({
      camera: vp.camera,
      canvas: vp.renderer.domElement,
      target: () => (this.surface && this.state.brush.on ? this.surface.pickMesh : null),
      sigmaAt: (p) => evaluateAt(this.sigmaBody(), p),
      setOrbit: (on) => (vp.controls.enabled = on),
      stamp: (b, t, first) => this.stamp(b, t, first),
      strokeEnd: () => this.save(),
      hover: (_p, ev) => {
        this.hoverEvent = ev;
        vp.interacting();
      },
    });
    this.brush.enabled = this.state.brush.on;
    vp.scene.add(this.brush.object3d);
    this.panel = new Panel(host.panel, this.state, assets, {
      objectChanged: () => void this.load(),
      upload: (f) => void this.uploadFile(f),
      sigmaChanged: () => this.sigmaEdited(true),
      presetChosen: () => this.applyPreset(),
      undoStroke: () => this.undo(),
      resetSigma: () => this.reset(),
      levelsChanged: () => this.levelsChanged(),
      styleChanged: () => this.restyle(),
      sliceChanged: () => this.sliceChanged(),
      exportShown: () => void this.exportShown(),
    });
    this.offs.push(
      socket.onFrame((f) => this.onFrame(f)),
      socket.onOpen(() => this.onSocketOpen()),
      vp.onBeforeRender(() => this.beforeRender()),
      vp.onAfterRender((ms) => this.afterRender(ms)),
    );
    installHooks(this);
    this.restyle();
    await this.load();
  }

  // ---- read-only views for the test hooks ----
  get currentObjectId(): string | null {
    return this.objectId;
  }
  get currentStatus(): ObjectStatus | null {
    return this.status;
  }
  get frames(): IsoFrameInfo[] {
    return this.frameLog;
  }
  get shownFrames(): IsoFrameInfo[] {
    return this.iso.shown();
  }
  get sigma(): { body: SigmaBody; version: number } {
    return { body: this.sigmaBody(), version: this.sigmaVersion };
  }
  get stateJson(): Record<string, unknown> {
    return writeStateJson(this.state);
  }
  get view(): Viewport | null {
    return this.viewport;
  }
  get displayTriangles(): number {
    return this.surface?.displayTriangles ?? 0;
  }
  /** σ at the input mesh's vertices, evaluated here (the server sends the same as surface scalars). */
  localSigmaAtInputVertices(): number[] {
    if (!this.surface) return [];
    const pos = this.surface.pickMesh.geometry.getAttribute("position").array as Float32Array;
    return Array.from(evaluateAll(this.sigmaBody(), pos));
  }
  /** True once the object is ready and every watched level has a frame for the current σ. */
  get ready(): boolean {
    if (!this.objectId || !this.surface) return false;
    const shown = this.iso.shown();
    return this.state.levels.every((l) => shown.some((s) => s.level === l && s.sigma_version >= this.sigmaVersion));
  }
  get sliceSigmaVersion(): number {
    return this.slice?.lastSigmaVersion ?? -1;
  }
  get probeReading() {
    return this.probe?.last ?? null;
  }

  // ---- the object ----
  private async load(): Promise<void> {
    const ticket = ++this.ticket;
    await this.job?.cancel();
    this.job = null;
    const old = this.objectId ?? this.pendingId;
    if (old) void api.del(`/api/kelvin/objects/${old}`).catch(() => undefined);
    this.objectId = this.pendingId = null;
    this.status = null;
    this.dropSurface();
    this.socketSurface = null;
    this.surfaceWaiter?.cancel();
    this.surfaceSource = null;
    this.iso.clear();
    this.iso.setLevels(this.state.levels);
    this.slice?.setObject(null, new THREE.Box3());
    this.probe?.setObject(null, new THREE.Box3());
    this.sigmaVersion = 0;
    this.save();
    const source: Source = this.state.object === "upload" && this.upload ? this.upload : { asset: this.state.object };
    const name = "asset" in source ? source.asset : source.name;
    const job = (this.job = new ObjectJob());
    const t0 = performance.now();
    const label = (stage: string) => `preparing ${name} (l_x = ${this.state.lx})${stage ? ": " + stage : ""}`;
    this.host.progress(label(""), undefined, () => void job.cancel());
    this.host.status(label(""));
    let status: ObjectStatus;
    try {
      status = await job.prepare(source, this.state.lx, { sigma: this.sigmaBody(), levels: this.state.levels }, {
        progress: (stage, fraction, cancel) => ticket === this.ticket && this.host.progress(label(stage), fraction, cancel),
        created: (id) => ticket === this.ticket && this.adopt(id),
      });
    } catch (e) {
      if (ticket !== this.ticket) return;
      this.host.progress(null);
      const text = e instanceof ApiError && e.code === "cancelled" ? "preparation cancelled" : showError(e, `cannot prepare ${name}`);
      this.host.status(text);
      this.panel?.setStats([["object", `${name}: ${text}`]]);
      return;
    }
    if (ticket !== this.ticket) return;
    this.timings.prepareMs.push(performance.now() - t0);
    this.status = status;
    this.objectId = status.id;
    try {
      const frame = await this.surfaceOf(status.id);
      if (ticket !== this.ticket) return;
      this.showSurface(frame);
    } catch (e) {
      if (ticket === this.ticket) showError(e, "cannot fetch the surface");
    }
    this.host.progress(null);
    this.updateStats();
  }

  /** The ready object's surface: the frame the server pushes on the socket once per object (it
   *  may have come already); by REST only when the socket is closed or the frame does not come. */
  private surfaceOf(id: string): Promise<MeshFrame> {
    const pushed = this.socketSurface;
    this.socketSurface = null;
    if (pushed?.object === id) {
      this.surfaceSource = "socket";
      return Promise.resolve(pushed);
    }
    return new Promise<MeshFrame>((resolve, reject) => {
      let settled = false;
      const settle = (f: MeshFrame | null, e?: unknown) => {
        if (settled) return;
        settled = true;
        window.clearTimeout(timer);
        if (this.surfaceWaiter === waiter) this.surfaceWaiter = null;
        if (f) resolve(f);
        else reject(e);
      };
      const waiter = {
        id,
        take: (f: MeshFrame) => {
          if (!settled) this.surfaceSource = "socket";
          settle(f);
        },
        cancel: () => settle(null, new ApiError(0, "cancelled", "another object was chosen")),
      };
      const fromRest = () => {
        if (settled) return;
        api.get<MeshFrame>(`/api/kelvin/objects/${id}/surface`).then(
          (f) => {
            if (!isMeshFrame(f)) return settle(null, new Error("the server's surface is not a mesh frame"));
            if (!settled) this.surfaceSource = "rest";
            settle(f);
          },
          (e) => settle(null, e),
        );
      };
      this.surfaceWaiter = waiter;
      const timer = window.setTimeout(fromRest, socket.state === "open" ? SURFACE_SOCKET_WAIT_MS : 0);
    });
  }

  private adopt(id: string): void {
    this.pendingId = id;
    const mine = this.unclaimed.filter((f) => f.object === id);
    this.unclaimed = this.unclaimed.filter((f) => f.object !== id);
    mine.forEach((f) => this.onFrame(f));
  }

  private showSurface(frame: MeshFrame): void {
    const vp = this.viewport!;
    this.dropSurface();
    const s = (this.surface = new SurfaceLayer(frame));
    s.setScale(this.state.sigmaScale);
    s.setSigma(this.sigmaBody());
    vp.scene.add(s.mesh);
    const size = s.bounds.getSize(new THREE.Vector3()).length();
    if (this.state.brush.radius <= 0) {
      this.state.brush.radius = Number((size * 0.08).toPrecision(2));
      this.state.brush.falloff = Number((size * 0.04).toPrecision(2));
      this.panel?.refresh();
    }
    this.restyle();
    const view = s.bounds.clone().expandByScalar(size * 0.2);
    vp.frame(view);
    this.warmUp();
    this.slice?.setObject(this.objectId, s.bounds);
    this.probe?.setObject(this.objectId, s.bounds);
    this.sliceChanged();
  }

  /** The brush cursor and the probe stay hidden until the pointer first hovers or paints. Their
   *  programs are linked now, while the object loads, and used once in a frame drawn over at
   *  once: on a software renderer the first use's synchronous GL queries wait for the GPU
   *  process to finish the frame before (measured 50-125 ms each in the first stroke). */
  private warmUp(): void {
    const vp = this.viewport;
    if (!vp || !this.brush || !this.probe) return;
    const hidden = [this.brush.object3d, this.probe.arrow, this.probe.marker].filter((o) => !o.visible);
    hidden.forEach((o) => (o.visible = true));
    vp.renderer.render(vp.scene, vp.camera);
    hidden.forEach((o) => (o.visible = false));
    vp.renderer.render(vp.scene, vp.camera); // what the user sees (the drawing buffer is preserved)
  }

  private dropSurface(): void {
    if (!this.surface) return;
    this.viewport?.scene.remove(this.surface.mesh);
    this.surface.dispose();
    this.surface = null;
  }

  private async uploadFile(file: File): Promise<void> {
    this.host.progress(`uploading ${file.name}`);
    try {
      const r = await uploadMesh(file);
      toast(`${file.name}: ${r.n_vertices} vertices, ${r.n_faces} triangles`, "ok");
      this.upload = { upload: r.upload, name: file.name };
      this.state.object = "upload";
      this.state.preset = "none";
      this.state.brushes = [];
      this.state.brush.radius = 0;
      this.strokes = [];
      this.panel?.refresh();
      await this.load();
    } catch (e) {
      this.host.progress(null);
      const text = showError(e, `cannot use ${file.name}`);
      this.host.status(text);
    }
  }

  private onSocketOpen(): void {
    if (this.firstOpen) {
      this.firstOpen = false;
      return;
    }
    // After a reconnect: the server may have restarted (sessions are in memory). The prepared
    // object comes back from its cache when re-created with the same inputs. If it still knows
    // the object, joining already sent this socket its surface and frames (no "state" request:
    // that would send the whole surface a second time).
    const id = this.objectId;
    if (!id) return;
    api.get<ObjectStatus>(`/api/kelvin/objects/${id}`).then(
      () => undefined,
      (e) => {
        if (id !== this.objectId) return;
        if (e instanceof ApiError && e.status === 404) {
          toast("the server forgot this object (restarted?): preparing it again", "info");
          if (this.state.object === "upload") {
            this.state.object = "cube";
            this.state.lx = defaultLx.cube;
          }
          void this.load();
        }
      },
    );
  }

  private onFrame(f: BinaryFrame): void {
    if ((f.type !== "isosurface" && f.type !== "surface") || !isMeshFrame(f)) return;
    if (f.object !== this.objectId && f.object !== this.pendingId) {
      // A prepared object shared from the server's memory is ready (and its frames pushed)
      // before our POST has returned its id: keep a few unclaimed frames for adopt().
      this.unclaimed.push(f);
      if (this.unclaimed.length > 32) this.unclaimed.shift();
      return;
    }
    if (f.type === "surface") {
      // Once per object (again after a reconnect, with the current σ, which the page computes
      // itself): only the first is used.
      if (this.surface || f.object !== (this.objectId ?? this.pendingId)) return;
      const waiter = this.surfaceWaiter;
      if (waiter && waiter.id === f.object) waiter.take(f);
      else this.socketSurface = f;
      return;
    }
    const t0 = performance.now();
    const info = this.iso.accept(f, Number(f.level), Number(f.sigma_version ?? 0));
    if (!info) return;
    // The frame completes this σ's edit, or an older one's that the server skipped for it.
    const traces = [...this.awaitingDraw].filter(([v]) => v <= info.sigma_version).map(([, t]) => t);
    if (this.inflight && info.sigma_version > this.sigmaVersion) traces.push(this.inflight);
    const t1 = performance.now();
    for (const trace of traces) {
      trace.arrived = socket.frameArrivedAt;
      trace.decodeMs += t0 - socket.frameArrivedAt;
      trace.acceptMs += t1 - t0;
      trace.processed = t1;
      const server = f.server_ms as { since_edit?: number } | undefined;
      trace.serverMs = Math.max(trace.serverMs, server?.since_edit ?? 0);
    }
    this.frameLog.push(info);
    if (this.frameLog.length > 500) this.frameLog.shift();
    this.viewport?.invalidate();
    this.checkWaiters();
  }

  // ---- σ ----
  private sigmaBody(): SigmaBody {
    return composeSigma(this.state.preset, this.state.base, this.state.brushes);
  }

  private stamp(b: Brush, eventTime: number, strokeStart: boolean): void {
    if (!this.surface) return;
    if (strokeStart) this.strokes.push(this.state.brushes.length);
    this.state.brushes.push(b);
    this.surface.addBrush(b);
    this.localPending.push(eventTime);
    this.unsentSince ??= eventTime;
    this.viewport?.interacting();
    this.sigmaSync.push();
  }

  /** Whole-σ changes (preset, base, reset, undo). */
  private sigmaEdited(save: boolean): void {
    this.surface?.setSigma(this.sigmaBody());
    this.unsentSince ??= performance.now();
    this.viewport?.invalidate();
    this.sigmaSync.push();
    if (save) this.save();
  }

  /** σ to the server: on the socket when open (no HTTP request per edit), else by PUT. The
   *  server answers a socket edit with a "sigma" message carrying its version, or an error, both
   *  echoing the edit's request id. A σ is a whole state, so an edit whose answer was lost with
   *  the connection is simply sent again by PUT. */
  private async putSigma(id: string, body: SigmaBody): Promise<number> {
    const answer = socket.request({ type: "sigma", object: id, sigma: body });
    if (answer) {
      try {
        const m = await answer;
        if (m.type === "sigma" && m.object === id) return Number(m.sigma_version);
        const e = m.error as { code?: string; message?: string; field?: string } | undefined;
        throw new ApiError(Number(m.status ?? 500), e?.code ?? "error", e?.message ?? "σ not applied", e?.field);
      } catch (e) {
        if (!(e instanceof SocketRequestError)) throw e;
      }
    }
    return api.put<{ sigma_version: number }>(`/api/kelvin/objects/${id}/sigma`, body).then((r) => r.sigma_version);
  }

  private async sendSigma(): Promise<void> {
    const id = this.objectId;
    if (!id) return;
    const since = this.unsentSince;
    this.unsentSince = null;
    const sent = performance.now();
    const trace: EditTrace = { since: since ?? sent, sent, answered: 0, arrived: 0, processed: 0, decodeMs: 0, acceptMs: 0, serverMs: 0, raf: 0 };
    this.inflight = trace;
    try {
      const version = await this.putSigma(id, this.sigmaBody());
      this.inflight = null;
      if (id !== this.objectId) return;
      trace.answered = performance.now();
      if (since !== null) this.awaitingDraw.set(version, trace); // drawn at the next frame if its frames came first
      this.sigmaVersion = Math.max(this.sigmaVersion, version);
      this.viewport?.invalidate();
      this.slice?.refresh();
      // Wait for this σ's frames before sending the next edit: the server then always works on
      // the newest σ and the screen never lags behind a queue of stale edits.
      await this.framesFor(version, 3000);
    } catch (e) {
      this.inflight = null;
      showError(e, "σ not applied");
    }
  }

  private framesFor(version: number, timeoutMs: number): Promise<void> {
    return new Promise((resolve) => {
      const w = { version, resolve };
      this.waiters.push(w);
      window.setTimeout(() => {
        this.waiters = this.waiters.filter((x) => x !== w);
        resolve();
      }, timeoutMs);
      this.checkWaiters();
    });
  }

  private allShownAtLeast(version: number): boolean {
    const shown = this.iso.shown();
    return this.state.levels.every((l) => shown.some((s) => s.level === l && s.sigma_version >= version));
  }

  private checkWaiters(): void {
    this.waiters = this.waiters.filter((w) => {
      if (!this.allShownAtLeast(w.version)) return true;
      w.resolve();
      return false;
    });
  }

  private beforeRender(): void {
    const now = performance.now();
    for (const [version, t] of this.awaitingDraw)
      if (this.allShownAtLeast(version)) {
        t.raf = now;
        this.drawing.push([version, t]);
        this.awaitingDraw.delete(version);
      }
    // The slice follows σ: resample when it shows an older σ than the current one.
    if (this.slice && this.state.slice.show && this.sliceAtVersion !== this.sigmaVersion && this.slice.lastSigmaVersion >= 0) {
      this.sliceAtVersion = this.sigmaVersion;
      this.slice.refresh();
    }
    if (this.hoverEvent) this.hover(this.hoverEvent);
    this.hoverEvent = null;
  }

  private afterRender(renderMs: number): void {
    const now = performance.now();
    for (const t of this.localPending) this.timings.strokeToColourMs.push(now - t);
    this.localPending = [];
    for (const [version, t] of this.drawing) {
      const ready = Math.max(t.processed, t.answered);
      this.timings.strokeToFrameMs.push({
        version,
        ms: now - t.since,
        waitMs: t.sent - t.since,
        putMs: t.answered - t.sent,
        serverMs: t.serverMs,
        framesMs: t.arrived - t.sent,
        decodeMs: t.decodeMs,
        acceptMs: t.acceptMs,
        rafWaitMs: t.raf - ready,
        renderMs,
        drawMs: now - ready,
        fieldVertices: this.status?.stats?.n_verts ?? 0,
        lx: this.state.lx,
      });
    }
    this.drawing = [];
  }

  private applyPreset(): void {
    const p = this.state.preset;
    this.state.brushes = [];
    this.strokes = [];
    if (p !== "none" && this.state.object !== presets[p].asset) {
      this.state.object = presets[p].asset;
      this.state.lx = defaultLx[this.state.object] ?? this.state.lx;
      this.state.brush.radius = 0;
      this.panel?.refresh();
      void this.load();
      return;
    }
    this.panel?.refresh();
    this.sigmaEdited(true);
  }

  private undo(): void {
    const n = this.strokes.pop();
    if (n === undefined) return;
    this.state.brushes.length = n;
    this.sigmaEdited(true);
  }

  private reset(): void {
    this.state.brushes = [];
    this.strokes = [];
    this.state.preset = "none";
    this.state.base = DEFAULT_BASE;
    this.panel?.refresh();
    this.sigmaEdited(true);
  }

  // ---- levels, slice, probe, style ----
  private levelsChanged(): void {
    this.iso.setLevels(this.state.levels);
    this.save();
    const id = this.objectId;
    if (id) void api.put(`/api/kelvin/objects/${id}/levels`, { levels: this.state.levels }).catch((e) => showError(e, "levels"));
    this.viewport?.invalidate();
  }

  private sliceChanged(): void {
    const s = this.state.slice;
    this.slice?.configure(s.axis, s.offset, s.show);
    this.save();
    this.viewport?.invalidate();
  }

  private restyle(): void {
    this.iso.setVisible(this.state.showIso);
    this.iso.setOpacity(this.state.opacity);
    if (this.brush) {
      this.brush.enabled = this.state.brush.on;
      this.brush.settings = { value: this.state.brush.value, radius: this.state.brush.radius, falloff: this.state.brush.falloff };
    }
    this.surface?.setScale(this.state.sigmaScale);
    this.save();
    this.viewport?.invalidate();
  }

  private hover(ev: PointerEvent): void {
    const vp = this.viewport;
    if (!vp || !this.probe || this.brush?.isPainting || ev.buttons !== 0) return;
    const r = vp.renderer.domElement.getBoundingClientRect();
    const ray = new THREE.Raycaster();
    ray.setFromCamera(new THREE.Vector2(((ev.clientX - r.left) / r.width) * 2 - 1, -((ev.clientY - r.top) / r.height) * 2 + 1), vp.camera);
    const targets: THREE.Object3D[] = [];
    if (this.slice?.plane.visible) targets.push(this.slice.plane);
    else if (this.state.showIso) targets.push(...this.iso.meshes());
    const hit = ray.intersectObjects(targets, false)[0];
    if (hit) this.probe.at(hit.point);
  }

  // ---- export ----
  private async exportShown(): Promise<void> {
    const id = this.objectId;
    if (!id) return void toast("no object yet", "info");
    const name = this.state.object === "upload" && this.upload && "name" in this.upload ? this.upload.name.replace(/\.[^.]+$/, "") : this.state.object;
    for (const level of this.state.levels) {
      try {
        const { blob } = await api.binary(`/api/kelvin/objects/${id}/export?level=${level}&format=${this.state.format}`);
        const a = document.createElement("a");
        a.href = URL.createObjectURL(blob);
        a.download = `${name}-h${level}.${this.state.format}`;
        a.click();
        window.setTimeout(() => URL.revokeObjectURL(a.href), 2000);
      } catch (e) {
        showError(e, `export of level ${level}`);
      }
    }
  }

  // ---- bookkeeping ----
  private save(): void {
    this.host.saveState(writeStateJson(this.state));
  }

  private updateStats(): void {
    const st = this.status?.stats ?? {};
    const f = (x: unknown, d = 3) => (typeof x === "number" ? x.toFixed(d) : "–");
    const name = this.state.object === "upload" && this.upload && "name" in this.upload ? this.upload.name : this.state.object;
    this.panel?.setStats([
      ["object", `${name}, l_x = ${this.state.lx}`],
      ["input surface", `${this.surface?.inputVertices ?? "–"} vertices`],
      ["n_verts / n_tets", `${st.n_verts ?? "–"} / ${st.n_tets ?? "–"}`],
      ["size", `${f(st.size_mb, 1)} MB`],
      ["t_mesh / t_build / t_decomp", `${f(st.t_mesh)} / ${f(st.t_build)} / ${f(st.t_decomp)} s`],
      ["cache", st.cache_hit ? `hit (load ${f(st.t_load)} s)` : st.shared ? "shared in memory" : "computed"],
      ["prepared in", `${f((this.timings.prepareMs.at(-1) ?? NaN) / 1000, 2)} s (this page)`],
    ]);
    this.host.status(`${name} · ${st.n_verts ?? "?"} field vertices · drag on the surface paints σ, elsewhere orbits (b: brush off)`);
  }

  unmount(): void {
    this.ticket++;
    void this.job?.cancel();
    this.sigmaSync.cancelPending();
    this.surfaceWaiter?.cancel();
    this.offs.forEach((f) => f());
    this.offs = [];
    this.brush?.dispose();
    this.probe?.dispose();
    this.slice?.dispose();
    this.panel?.dispose();
    this.dropSurface();
    this.viewport?.dispose();
    this.viewport = null;
    const d = (window as unknown as { distlab?: { kelvin?: unknown } }).distlab;
    if (d) delete d.kelvin;
  }

  shortcuts(): Shortcut[] {
    const toggle = (f: () => void) => () => {
      f();
      this.panel?.refresh();
    };
    return [
      { key: "b", description: "brush on/off (paint σ by dragging on the surface)", run: toggle(() => ((this.state.brush.on = !this.state.brush.on), this.restyle())) },
      { key: "z", description: "undo the last σ stroke", run: () => this.undo() },
      { key: "r", description: "reset σ", run: () => this.reset() },
      { key: "s", description: "slice plane on/off", run: toggle(() => ((this.state.slice.show = !this.state.slice.show), this.sliceChanged())) },
      { key: "i", description: "iso-surfaces on/off", run: toggle(() => ((this.state.showIso = !this.state.showIso), this.restyle())) },
      { key: "e", description: "export the shown iso-surfaces", run: () => void this.exportShown() },
      { key: "[", description: "smaller brush", run: toggle(() => ((this.state.brush.radius *= 0.8), this.restyle())) },
      { key: "]", description: "larger brush", run: toggle(() => ((this.state.brush.radius *= 1.25), this.restyle())) },
      { key: "f", description: "frame the object", run: () => this.surface && this.viewport?.frame(this.surface.bounds.clone().expandByScalar(this.surface.bounds.getSize(new THREE.Vector3()).length() * 0.2)) },
    ];
  }

  screenshot(): Promise<Blob> {
    if (!this.viewport) return Promise.reject(new Error("no view"));
    return this.viewport.screenshot();
  }
}
