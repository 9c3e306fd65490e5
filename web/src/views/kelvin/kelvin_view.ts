// View 2, the semantic distance explorer (issue 5): prepare a Kelvin object (built-in or
// uploaded) with a progress bar, paint σ on its surface, watch iso-surfaces of h pushed by the
// server, slice h on a plane, probe h and ∇h, export iso-surfaces. State lives in the URL. An
// upload is drawn with its defects before it is prepared, with the repair's options; a link names
// it by its digest and never shows another object (issue 37).
import * as THREE from "three";
import { api, ApiError } from "../../core/api";
import { ColorBar } from "../../core/colorbar";
import { HistogramPlot } from "../../core/histogram";
import type { Shortcut } from "../../core/keys";
import { floats, isMeshFrame, toGeometry, uints, type MeshFrame } from "../../core/meshframe";
import { socket, type BinaryFrame } from "../../core/socket";
import { dismissToasts, showError, toast } from "../../core/toast";
import { linkFor } from "../../core/urlstate";
import type { View, ViewHost } from "../../core/view";
import { Viewport } from "../../core/viewport";
import { BrushTool } from "./brush_tool";
import { EditTracer } from "./edit_trace";
import { downloadIsoSurfaces } from "./iso_export";
import { IsoLayers, type IsoFrameInfo } from "../../core/iso_layers";
import { IsoLegend } from "../../core/iso_legend";
import { DEFAULT_BASE, defaultLx, readState, writeStateJson, type KelvinState, type UploadUnit } from "./kelvin_state";
import {
  ObjectJob,
  estimate,
  estimateText,
  repairEstimateText,
  repairText,
  reuseUpload,
  sourceBody,
  uploadGeometry,
  uploadMesh,
  uploadText,
  type Estimate,
  type ObjectStatus,
  type Source,
  type Uploaded,
} from "./object_source";
import { statsRows, statusLine } from "./object_stats";
import { Panel } from "./panel";
import { Probe } from "./probe";
import { composeSigma, evaluateAll, evaluateAt, linkPrecision, presets, type Brush, type SigmaBody } from "./sigma";
import { brushesDigest, parseSigmaFile, sigmaFileText, SigmaFileError } from "./sigma_file";
import { SigmaSync } from "./sigma_sync";
import { SliceLayer } from "./slice_layer";
import { SurfaceLayer } from "./surface_layer";
import { SurfaceSource } from "./surface_source";
import { defectColors, defectLines, DefectsLayer, holeSizes, isClosedManifold } from "./upload_defects";
import { UploadNotice } from "./upload_link";
import { lxNote, suggestedLx } from "./lx_note";
import { TimeLeft, timeLeftText } from "./time_left";
import { repairAdvice, type Advice } from "./repair_advice";
import { installHooks, type Timings } from "./test_hooks";
import type { Limits } from "../../core/wire";
import "./kelvin.css";

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
  private uploadedFile: File | null = null; // uploaded again when its unit changes
  private uploadLine = ""; // the upload dialog's first line: what the server read
  private overlay: THREE.LineSegments | null = null; // a repair's surface over the input's
  private defectsLayer: DefectsLayer | null = null; // the upload as its file has it, defects marked
  private advice: Advice | null = null; // the repair its defects call for
  private notice: UploadNotice | null = null; // a link's upload that this server does not hold
  private awaitPrepare = false; // an upload's repair is being chosen: prepared on request
  /** The server's estimate of each request asked here (JSON of its body), and the text shown for the current one. */
  private readonly estimates = new Map<string, Estimate>();
  private estimateShown = "";
  private pendingCamera: KelvinState["camera"] = undefined; // a link's camera, for the first framing
  private framedKey = ""; // what the camera was last framed on (an asset, an upload's digest)
  private limits: Partial<Limits> = {};
  private ticket = 0;
  private loads = 0; // load() calls running: a field may be on its way
  private offs: Array<() => void> = [];
  private strokes: number[] = []; // brushes.length at each stroke's start (undo)
  private sigmaVersion = 0;
  private frameLog: IsoFrameInfo[] = [];
  private readonly timings: Timings = { prepareMs: [], strokeToFrameMs: [], strokeToColourMs: [], sliceMs: [] };
  private edits = new EditTracer(this.timings);
  private sigmaSync = new SigmaSync(
    {
      objectId: () => this.objectId,
      body: () => this.sigmaBody(),
      applied: (version) => this.sigmaApplied(version),
      shownAtLeast: (version) => this.allShownAtLeast(version),
    },
    this.edits,
  );
  private surfaces = new SurfaceSource();
  private hoverEvent: PointerEvent | null = null;
  private firstOpen = true;
  private sliceAtVersion = -1;
  private sigmaBar: ColorBar | null = null;
  private hBar: ColorBar | null = null;
  private isoLegend: IsoLegend | null = null;
  private histogram: HistogramPlot | null = null;
  private assets: string[] = [];
  private longLinkTold = false;

  async mount(host: ViewHost, raw: Record<string, unknown>): Promise<void> {
    this.host = host;
    this.state = readState(raw);
    this.pendingCamera = this.state.camera;
    const vp = (this.viewport = new Viewport(host.canvas));
    vp.grid.visible = false;
    vp.scene.add(this.iso.group);
    const [limits, assets] = await Promise.all([
      api.get<Limits>("/api/limits").catch(() => ({}) as Limits),
      api
        .get<{ assets: string[] }>("/api/kelvin/assets")
        .then((r) => r.assets)
        .catch((e) => (showError(e, "cannot list the built-in objects"), ["cube"])),
    ]);
    if (this.viewport !== vp) return; // unmounted meanwhile
    this.limits = limits;
    this.slice = new SliceLayer(limits.max_query_points ?? 10000);
    this.slice.onError = (e) => showError(e, "slice");
    this.slice.onSampled = () => {
      this.timings.sliceMs.push(this.slice!.lastSampleMs);
      this.updateHBar();
      vp.invalidate();
    };
    this.slice.setColor(this.state.sliceColor);
    this.sigmaBar = new ColorBar(host.canvas, "σ on the surface", "dimensionless", "colorbar-sigma");
    this.hBar = new ColorBar(host.canvas, "h on the slice", "dimensionless, −ln U", "colorbar-h");
    this.isoLegend = new IsoLegend(host.canvas, "iso-surfaces of h (dimensionless)", (l) => (l === 0 ? "(zero level set)" : ""));
    vp.scene.add(this.slice.plane);
    this.probe = new Probe(host.canvas);
    this.probe.onChange = () => vp.invalidate();
    vp.scene.add(this.probe.arrow, this.probe.marker);
    this.brush = new BrushTool({
      camera: vp.camera,
      canvas: vp.renderer.domElement,
      target: () => (this.surface && this.state.brush.on ? this.surface.pickMesh : null),
      stampAt: (settings, centre) => this.surface?.stampAt(settings, centre) ?? null,
      setOrbit: (on) => (vp.controls.enabled = on),
      stamp: (b, t, first) => this.stamp(b, t, first),
      strokeEnd: () => {
        this.save();
        this.updateHistogram();
      },
      hover: (_p, ev) => {
        this.hoverEvent = ev;
        vp.interacting();
      },
    });
    this.brush.enabled = this.state.brush.on;
    vp.scene.add(this.brush.object3d);
    this.panel = new Panel(host.panel, this.state, assets, {
      objectChanged: () => this.objectSwitched(),
      lxChanged: () => void this.load(),
      upload: (f) => void this.uploadFile(f),
      unitChanged: () => {
        if (this.uploadedFile && this.state.object === "upload") void this.uploadFile(this.uploadedFile);
        else this.save();
      },
      repairChanged: () => this.repairChanged(),
      sigmaChanged: () => this.sigmaEdited(true),
      presetChosen: () => this.applyPreset(),
      undoStroke: () => this.undo(),
      resetSigma: () => this.reset(),
      levelsChanged: () => this.levelsChanged(),
      styleChanged: () => this.restyle(),
      sliceChanged: () => this.sliceChanged(),
      sliceStyleChanged: () => this.sliceStyleChanged(),
      exportShown: () => void this.exportShown(),
      saveSigma: () => this.saveSigma(),
      loadSigma: (f) => void this.loadSigma(f),
      prepare: () => this.prepareNow(),
      defectsToggled: () => this.showDefectMarks(),
      frame: () => this.frameObject(),
      copyLink: () => void this.copyLink(),
    });
    this.panel.setRepairLimits(limits);
    this.assets = assets;
    this.notice = new UploadNotice(host.canvas, (f) => void this.uploadFile(f));
    const cameraMoved = () => this.cameraMoved();
    vp.controls.addEventListener("end", cameraMoved);
    this.offs.push(() => vp.controls.removeEventListener("end", cameraMoved));
    this.showSigmaNotice();
    if (limits.min_lx !== undefined) this.panel.setMinLx(limits.min_lx);
    this.histogram = new HistogramPlot(this.panel.sigmaHistogram, "σ (dimensionless)", "% of vertices");
    this.offs.push(
      socket.onFrame((f) => this.onFrame(f)),
      socket.onOpen(() => this.onSocketOpen()),
      vp.onBeforeRender(() => this.beforeRender()),
      vp.onAfterRender((ms) => this.afterRender(ms)),
    );
    installHooks({
      viewport: () => this.viewport,
      objectId: () => this.objectId,
      status: () => this.status,
      ready: () => Boolean(this.objectId && this.surface) && this.allShownAtLeast(this.sigmaVersion),
      overlayTriangles: () => (this.overlay ? this.overlay.userData.triangles : 0),
      upload: () => this.uploadHooks(),
      surfaceSource: () => this.surfaces.origin,
      frames: () => this.frameLog,
      shown: () => this.iso.shown(),
      sigma: () => ({ body: this.sigmaBody(), version: this.sigmaVersion }),
      stateJson: () => writeStateJson(this.state),
      timings: () => this.timings,
      sliceSigmaVersion: () => this.slice?.lastSigmaVersion ?? -1,
      probe: () => this.probe?.last ?? null,
      displayTriangles: () => this.surface?.displayTriangles ?? 0,
      surface: () => this.surface,
      localSigmaAtInputVertices: () => {
        const pos = this.surface?.pickMesh.geometry.getAttribute("position").array as Float32Array | undefined;
        return pos ? Array.from(evaluateAll(this.sigmaBody(), pos)) : [];
      },
      colorbars: () => [this.sigmaBar?.state, this.hBar?.state].filter((b) => b != null),
      sigmaHistogram: () => this.histogram?.data ?? null,
      isoLegend: () => this.isoLegend?.rows ?? [],
      shells: () =>
        this.iso.meshes().map((m) => {
          const mat = m.material as THREE.MeshLambertMaterial;
          return {
            level: this.iso.levelOf(m) ?? NaN,
            color: `#${mat.color.getHexString()}`,
            opacity: mat.opacity,
            facingOpacity: mat.userData.facingOpacity ?? 1,
            visible: m.visible && this.iso.group.visible,
          };
        }),
      pickAt: (x, y) => {
        const vp = this.viewport;
        if (!vp) return [];
        const r = vp.renderer.domElement.getBoundingClientRect();
        const ray = new THREE.Raycaster();
        ray.setFromCamera(new THREE.Vector2(((x - r.left) / r.width) * 2 - 1, -((y - r.top) / r.height) * 2 + 1), vp.camera);
        const targets: THREE.Object3D[] = [...(this.state.showIso ? this.iso.meshes() : []), ...(this.surface ? [this.surface.pickMesh] : [])];
        if (this.slice?.plane.visible) targets.push(this.slice.plane);
        return ray
          .intersectObjects(targets, false)
          .map((h) => (h.object === this.surface?.pickMesh ? "surface" : h.object === this.slice?.plane ? "slice" : `iso ${this.iso.levelOf(h.object)}`));
      },
    });
    this.restyle();
    if (this.state.object === "upload") await this.openLinkedUpload();
    else await this.load();
  }

  // ---- the object ----
  /** Prepares the object the state names (or waits for the user's repair), then says in the
   *  iso legend whether its shells are coming. */
  private async load(): Promise<void> {
    this.loads++;
    try {
      await this.loadObject();
    } finally {
      this.loads--;
      this.updateIsoLegend();
    }
  }

  private async loadObject(): Promise<void> {
    const ticket = ++this.ticket;
    await this.job?.cancel();
    this.job = null;
    const old = this.objectId ?? this.pendingId;
    if (old) void api.del(`/api/kelvin/objects/${old}`).catch(() => undefined);
    this.objectId = this.pendingId = null;
    this.status = null;
    this.dropSurface();
    this.dropOverlay();
    if (this.defectsLayer) {
      this.defectsLayer.group.visible = this.state.object === "upload";
      this.defectsLayer.setInputVisible(true);
    }
    this.surfaces.reset();
    this.iso.clear();
    this.iso.setLevels(this.state.levels);
    this.updateIsoLegend();
    this.slice?.setObject(null, new THREE.Box3());
    this.probe?.setObject(null, new THREE.Box3());
    this.sigmaVersion = 0;
    this.save();
    if (this.state.object === "upload" && !this.upload) {
      // A link's upload that this server does not hold: its notice, and no other object.
      if (!this.notice?.shown) this.notice?.show(this.state.upload ?? null);
      this.panel?.setEstimate("", null);
      this.host.progress(null);
      this.host.status(`waiting for ${this.objectName()} to be uploaded`);
      return;
    }
    const source: Source = this.state.object === "upload" && this.upload ? this.upload : { asset: this.state.object };
    const name = this.objectName();
    const repair = this.state;
    const uploadLines = this.state.object === "upload" && this.uploadLine ? [this.uploadLine] : [];
    this.panel?.setReport(uploadLines);
    // One estimate per request (object, l_x, reshaping): asked once, then the same text wherever
    // and whenever it is shown for that request (before, during and after its preparation).
    const key = JSON.stringify(sourceBody(source, this.state.lx, repair));
    let est: Estimate | undefined = this.estimates.get(key);
    if (!est) this.panel?.setEstimate("estimating…", null);
    try {
      est ??= await estimate(source, this.state.lx, repair);
      this.rememberEstimate(key, est);
    } catch (e) {
      if (ticket !== this.ticket) return;
      this.panel?.setLxNote("", null, () => {});
      // A refused l_x (below the server's minimum) is shown under the field; anything else is an error.
      if (e instanceof ApiError && e.field === "lx") this.panel?.setEstimate(`cannot prepare ${name}: ${e.readable}`, { field: "lx", message: e.message });
      else if (e instanceof ApiError && /^(repair|simplify|components)/.test(e.field ?? "")) {
        // A repair option the server refuses up front (a wrap over its budget): under the options.
        this.panel?.setEstimate(`cannot prepare ${name} with these repair options`, null);
        this.panel?.setRepairEstimate(`refused: ${e.readable}`, true);
      } else this.panel?.setEstimate(showError(e, `cannot estimate ${name}`), null);
      return;
    }
    if (ticket !== this.ticket) return;
    const note = lxNote(est, this.state.lx);
    this.panel?.setLxNote(note.text, note.suggestion, (lx) => {
      this.state.lx = lx;
      this.panel?.refresh();
      void this.load();
    });
    const pending = repair.repair !== "none" ? `the ${repair.repair}` : "the simplification";
    this.estimateShown = estimateText(est, pending);
    this.panel?.setEstimate(this.estimateShown, est.problem);
    this.panel?.setRepairEstimate(repairEstimateText(est, this.state));
    if (est.problem) {
      // l_x is flagged under its field; a refused mesh is an error of its own.
      const text = `${name} at l_x = ${this.state.lx}: ${est.problem.message}`;
      this.host.progress(null); // an upload's bar ends with the refusal
      if (est.problem.field !== "lx") {
        showError(new ApiError(422, "invalid_input", est.problem.message, est.problem.field), `cannot prepare ${name}`);
        this.panel?.setReport([...uploadLines, `refused: ${est.problem.message}`], true);
      }
      this.host.status(text);
      this.panel?.setStats([["object", text]]);
      return;
    }
    if (this.awaitPrepare && this.state.object === "upload") {
      // The user chooses the repair first; "prepare with these options" goes on.
      this.host.progress(null);
      this.panel?.setRepairEstimate(`${repairEstimateText(est, this.state)} · then "prepare with these options"`);
      this.host.status(`${name}: not prepared yet (choose the repair, then prepare)`);
      return;
    }
    const job = (this.job = new ObjectJob());
    const t0 = performance.now();
    // The bar is the job's overall fraction; the label says the stage and the time left, counted
    // down between the job's reports.
    const clock = new TimeLeft(est.seconds_estimate);
    let shown: { stage: string; fraction: number | undefined; cancel: () => void } | null = null;
    const label = (stage: string) => {
      const left = timeLeftText(clock.left());
      return `preparing ${name} (l_x = ${this.state.lx})${stage ? ": " + stage : ""}${left ? " · " + left : ""}`;
    };
    const countdown = window.setInterval(() => shown && ticket === this.ticket && this.host.progress(label(shown.stage), shown.fraction, shown.cancel), 500);
    this.host.progress(label(""), undefined, () => void job.cancel());
    this.host.status(label(""));
    let status: ObjectStatus;
    try {
      status = await job.prepare(
        source,
        this.state.lx,
        { sigma: this.sigmaBody(), levels: this.state.levels },
        {
          progress: (stage, fraction, cancel) => {
            if (ticket !== this.ticket) return;
            shown = { stage, fraction, cancel };
            clock.report(stage, fraction ?? 0);
            this.host.progress(label(stage), fraction, cancel);
          },
          created: (id) => ticket === this.ticket && this.adopt(id),
          repaired: (o) => ticket === this.ticket && void this.showRepair(o, uploadLines, ticket),
          // What the server could not predict before the repair made the surface, its job did.
          estimated: (o) => {
            if (ticket !== this.ticket || !o.estimate || est.vertices_predicted !== null) return;
            const known = { ...est, ...o.estimate };
            clock.predicted = known.seconds_estimate;
            this.rememberEstimate(key, known);
            this.estimateShown = estimateText(known);
            this.panel?.setEstimate(this.estimateShown, null);
          },
        },
        repair,
      );
    } catch (e) {
      window.clearInterval(countdown);
      if (ticket !== this.ticket) return;
      this.host.progress(null);
      const text = e instanceof ApiError && e.code === "cancelled" ? "preparation cancelled" : showError(e, `cannot prepare ${name}`);
      if (!(e instanceof ApiError && e.code === "cancelled")) this.panel?.setReport([...uploadLines, `refused: ${e instanceof Error ? e.message : String(e)}`], true);
      this.host.status(text);
      this.panel?.setStats([["object", `${name}: ${text}`]]);
      return;
    }
    window.clearInterval(countdown);
    if (ticket !== this.ticket) return;
    this.timings.prepareMs.push(performance.now() - t0);
    this.status = status;
    this.objectId = status.id;
    try {
      const frame = await this.surfaces.of(status.id);
      if (ticket !== this.ticket) return;
      this.showSurface(frame);
    } catch (e) {
      if (ticket === this.ticket) showError(e, "cannot fetch the surface");
    }
    this.host.progress(null);
    this.updateStats();
  }

  /** Another object: l_x and the brush follow its size (the previous object's would not fit). */
  private objectSwitched(): void {
    this.awaitPrepare = false;
    this.state.lx = defaultLx[this.state.object] ?? this.state.lx;
    this.state.brush.radius = 0; // chosen from the new surface's size when it arrives
    this.panel?.refresh();
    void this.load();
  }

  /** A repair's report, and its surface drawn as a wireframe over the input's (fetched once made,
   *  while the field is still being prepared on it). */
  private async showRepair(o: ObjectStatus, uploadLines: string[], ticket: number): Promise<void> {
    if (o.repair_report) this.panel?.setReport([...uploadLines, repairText(o.repair_report)]);
    try {
      const frame = await api.get<MeshFrame>(`/api/kelvin/objects/${o.id}/surface?of=repaired`);
      if (ticket !== this.ticket || !isMeshFrame(frame)) return;
      const g = toGeometry(frame);
      this.dropOverlay();
      const overlay = (this.overlay = new THREE.LineSegments(new THREE.WireframeGeometry(g), new THREE.LineBasicMaterial({ color: 0x2f7fd0, transparent: true, opacity: 0.5 })));
      overlay.userData.triangles = frame.n_faces;
      g.dispose();
      this.viewport?.scene.add(overlay);
      this.viewport?.invalidate();
    } catch (e) {
      if (ticket === this.ticket) showError(e, "cannot fetch the repaired surface");
    }
  }

  private dropOverlay(): void {
    if (!this.overlay) return;
    this.viewport?.scene.remove(this.overlay);
    this.overlay.geometry.dispose();
    (this.overlay.material as THREE.Material).dispose();
    this.overlay = null;
  }

  private adopt(id: string): void {
    this.pendingId = id;
    this.surfaces.claim(id).forEach((f) => this.onFrame(f));
  }

  private showSurface(frame: MeshFrame): void {
    const vp = this.viewport!;
    this.dropSurface();
    const s = (this.surface = new SurfaceLayer(frame));
    s.setColor(this.state.sigmaColor);
    s.setSigma(this.sigmaBody());
    vp.scene.add(s.mesh);
    this.defectsLayer?.setInputVisible(false); // the prepared object's own surface replaces it
    // A large surface gets a simplified stand-in for the frames drawn while orbiting (once made).
    void s.makeStandIn(vp.standInTriangles).then((standIn) => {
      if (standIn && this.surface === s) vp.setStandIn(s.mesh, standIn.geometry);
    });
    const size = s.bounds.getSize(new THREE.Vector3()).length();
    if (this.state.brush.radius <= 0) {
      this.state.brush.radius = Number((size * 0.08).toPrecision(2));
      this.state.brush.falloff = Number((size * 0.04).toPrecision(2));
      this.panel?.refresh();
    }
    this.restyle();
    this.updateHistogram();
    this.frameOnce(s.bounds);
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

  private frameObject(): void {
    const b = this.surface?.bounds ?? this.defectsLayer?.bounds;
    if (b) this.viewport?.frame(b.clone().expandByScalar(b.getSize(new THREE.Vector3()).length() * 0.2));
    this.cameraMoved();
  }

  /** The camera is framed once per object (not again when l_x or σ change): on a link's camera
   *  when it has one, else on the object. */
  private frameOnce(bounds: THREE.Box3): void {
    const key = this.state.object === "upload" ? `upload ${this.state.upload?.digest ?? ""}` : this.state.object;
    const vp = this.viewport;
    if (key === this.framedKey || !vp) return;
    this.framedKey = key;
    const c = this.pendingCamera;
    this.pendingCamera = undefined;
    if (!c) return this.frameObject();
    const r = Math.max(1e-3, bounds.getSize(new THREE.Vector3()).length() / 2);
    vp.camera.position.fromArray(c.position);
    vp.controls.target.fromArray(c.target);
    vp.camera.near = r / 100;
    vp.camera.far = r * 100 + vp.camera.position.distanceTo(vp.controls.target);
    vp.camera.updateProjectionMatrix();
    vp.controls.update();
    vp.invalidate();
    this.state.camera = c;
    this.save();
  }

  /** The camera goes into the link (to six significant digits). */
  private cameraMoved(): void {
    const vp = this.viewport;
    if (!vp) return;
    const round = (v: THREE.Vector3) => v.toArray().map((x) => Number(x.toPrecision(6)));
    this.state.camera = { position: round(vp.camera.position), target: round(vp.controls.target) };
    this.save();
  }

  private dropSurface(): void {
    if (this.sigmaBar) this.sigmaBar.visible = false;
    if (!this.surface) return;
    this.viewport?.scene.remove(this.surface.mesh);
    this.viewport?.setStandIn(this.surface.mesh, null);
    this.surface.dispose();
    this.surface = null;
  }

  // ---- uploads ----
  /** A file chosen in the panel, or in a link's notice: there, the server checks that it is the
   *  linked mesh (in the link's unit), and the link's view (σ, l_x, repair, camera) is kept. */
  private async uploadFile(file: File): Promise<void> {
    const fromLink = this.notice?.shown === true;
    const linked = fromLink ? (this.notice?.ref ?? undefined) : undefined;
    const unit: UploadUnit = linked?.unit ?? this.state.unit;
    this.host.progress(`uploading ${file.name}`);
    try {
      const r = await uploadMesh(file, unit, linked?.digest);
      this.uploadedFile = file;
      toast(`${file.name}: ${r.n_vertices} vertices, ${r.n_faces} triangles`, "ok");
      const name = linked?.name ?? file.name;
      this.state.upload = { digest: r.digest, name, bytes: r.bytes, unit };
      this.state.unit = unit;
      if (fromLink) {
        this.panel?.refresh();
        return await this.adoptUpload(r, name, true);
      }
      // A scan over what a preparation takes is simplified to that first (the Repair folder can lower it).
      const most = this.limits.max_object_triangles;
      if (most !== undefined && r.n_faces > most && (this.state.simplify === 0 || this.state.simplify > most)) {
        this.state.simplify = most;
        toast(`${file.name} has ${r.n_faces.toLocaleString("en")} triangles: it is simplified to ${most.toLocaleString("en")} first (Repair)`, "ok");
      }
      // l_x from the file's size: a thirtieth of its diagonal, coarser if over the budget.
      this.state.lx = suggestedLx(await estimate({ upload: r.upload, name }, this.state.lx, this.state));
      this.state.object = "upload";
      this.state.preset = "none";
      this.state.brushes = [];
      this.state.brush.radius = 0;
      this.strokes = [];
      this.panel?.refresh();
      await this.adoptUpload(r, name, false);
    } catch (e) {
      this.host.progress(null);
      if (fromLink && e instanceof ApiError && e.code === "different_mesh") {
        const text = `${file.name} is not the linked file: ${e.message}`;
        this.notice?.refused(text);
        this.host.status(text);
        return;
      }
      const text = showError(e, `cannot use ${file.name}`);
      this.host.status(text);
      if (fromLink) this.notice?.refused(text);
      else this.panel?.setReport([text], true);
    }
  }

  /** A link's upload: the server's copy when it holds that mesh, else the notice asking for the
   *  file (never another object). */
  private async openLinkedUpload(): Promise<void> {
    const ref = this.state.upload;
    this.upload = null;
    if (ref) this.state.unit = ref.unit;
    try {
      if (!ref) throw new ApiError(404, "upload_not_named", "the link does not name its upload");
      const r = await reuseUpload(ref.digest);
      if (!this.viewport || this.state.upload !== ref) return;
      await this.adoptUpload(r, ref.name, true);
    } catch (e) {
      if (!this.viewport || this.state.upload !== ref) return;
      if (!(e instanceof ApiError && e.status === 404)) showError(e, `cannot look up ${ref?.name ?? "the upload"}`);
      this.notice?.show(ref ?? null);
      // This page's own file, which a restarted server forgot: given again, checked against the link.
      if (ref && this.uploadedFile) return await this.uploadFile(this.uploadedFile);
      await this.load();
    }
  }

  /** An upload of this session becomes the object: drawn with its defects first; a fresh upload
   *  with defects waits for its repair to be chosen, a link's is prepared as the link says. */
  private async adoptUpload(r: Uploaded, name: string, fromLink: boolean): Promise<void> {
    this.upload = { upload: r.upload, name };
    this.uploadLine = uploadText(name, r);
    this.notice?.hide();
    this.panel?.setReport([this.uploadLine]);
    const clean = await this.showDefects(r.upload, fromLink);
    this.awaitPrepare = !fromLink && !clean;
    await this.load();
  }

  /** Draws the upload with its defects marked and lists them; true when it has none. */
  private async showDefects(id: string, fromLink: boolean): Promise<boolean> {
    this.dropDefects();
    let layer: DefectsLayer;
    try {
      const { frame, defects } = await uploadGeometry(id);
      if (!this.viewport || !this.upload || !("upload" in this.upload) || this.upload.upload !== id) return false;
      layer = this.defectsLayer = new DefectsLayer(frame, defects);
      this.advice = repairAdvice(defects, uints(frame.indices), floats(frame.positions), this.limits);
    } catch (e) {
      showError(e, "cannot draw the upload's defects");
      return false;
    }
    const d = layer.defects;
    layer.setMarksVisible(this.panel?.view.showDefects ?? true);
    this.viewport.scene.add(layer.group);
    const colors: Record<string, string> = {
      open: defectColors.open,
      edges: defectColors.nonManifold,
      vertices: defectColors.vertex,
      pair: defectColors.intersecting,
      degenerate: defectColors.intersecting,
      pieces: defectColors.dropped,
    };
    const color = (line: string) => Object.entries(colors).find(([k]) => line.includes(k))?.[1];
    const clean = isClosedManifold(d);
    this.panel?.setDefects([
      { text: clean ? "a closed 2-manifold without intersecting faces: no repair needed" : "defects (marked on the mesh):" },
      ...defectLines(d).map((text) => ({ text, color: color(text) })),
      ...(this.advice?.text ? [{ text: this.advice.text }] : []),
    ]);
    // A mesh over max_object_triangles was set to simplify on upload; simplify runs before any
    // repair and needs a closed surface, so a defective one takes the advice instead.
    if (!fromLink && this.advice && this.state.simplify > 0 && this.advice.simplify === 0) {
      Object.assign(this.state, { repair: this.advice.repair, simplify: 0, components: this.advice.components });
      this.panel?.refresh();
    }
    // A fresh upload's hole size: its largest hole, within this server's limit.
    const holes = d.truncated ? [] : holeSizes(d.boundary_edges as Array<[number, number]>);
    if (!fromLink && holes.length) {
      this.state.holeEdges = Math.min(holes[0], this.limits.max_hole_edges ?? holes[0]);
      this.panel?.refresh();
    }
    this.frameOnce(layer.bounds);
    this.viewport.invalidate();
    return clean;
  }

  private dropDefects(): void {
    this.advice = null;
    if (!this.defectsLayer) return;
    this.viewport?.scene.remove(this.defectsLayer.group);
    this.defectsLayer.dispose();
    this.defectsLayer = null;
    this.panel?.setDefects([]);
  }

  private showDefectMarks(): void {
    this.defectsLayer?.setMarksVisible(this.panel?.view.showDefects ?? true);
    this.viewport?.invalidate();
  }

  /** A repair option changed: an upload waits for "prepare", an asset is prepared at once. */
  private repairChanged(): void {
    if (this.state.object === "upload") this.awaitPrepare = true;
    void this.load();
  }

  private prepareNow(): void {
    this.awaitPrepare = false;
    void this.load();
  }

  private uploadHooks() {
    const layer = this.defectsLayer,
      vp = this.viewport;
    return {
      ref: this.state.upload ?? null,
      id: this.upload && "upload" in this.upload ? this.upload.upload : null,
      notice: this.notice?.text ?? null,
      refusal: this.notice?.refusalText ?? "",
      awaitingPrepare: this.awaitPrepare,
      defects: layer
        ? {
            counts: layer.defects.counts,
            vertices: layer.vertexCount,
            edges: layer.markedEdges(),
            inputShown: layer.inputVisible,
            marksShown: layer.marksVisible && layer.group.visible,
            advice: this.advice,
          }
        : null,
      camera: vp ? { position: vp.camera.position.toArray(), target: vp.controls.target.toArray() } : null,
    };
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
          // An upload is asked for again by its digest (or the notice says it is gone).
          if (this.state.object === "upload") void this.openLinkedUpload();
          else void this.load();
        }
      },
    );
  }

  private onFrame(f: BinaryFrame): void {
    if ((f.type !== "isosurface" && f.type !== "surface") || !isMeshFrame(f)) return;
    if (f.object !== this.objectId && f.object !== this.pendingId) return this.surfaces.keepUnclaimed(f); // perhaps ours soon
    if (f.type === "surface") {
      // Once per object (again after a reconnect, with the current σ, which the page computes
      // itself): only the first is used.
      if (!this.surface && f.object === (this.objectId ?? this.pendingId)) this.surfaces.surfacePushed(f);
      return;
    }
    const t0 = performance.now();
    const info = this.iso.accept(f, Number(f.level), Number(f.sigma_version ?? 0));
    if (!info) return;
    this.edits.frameAccepted(f, info.sigma_version, this.sigmaVersion, t0);
    this.frameLog.push(info);
    this.updateIsoLegend();
    if (this.frameLog.length > 500) this.frameLog.shift();
    this.viewport?.invalidate();
    this.sigmaSync.framesShown();
  }

  // ---- σ ----
  private sigmaBody(): SigmaBody {
    return composeSigma(this.state.preset, this.state.base, this.state.brushes);
  }

  private stamp(painted: Brush, eventTime: number, strokeStart: boolean): void {
    if (!this.surface) return;
    const b = linkPrecision(painted);
    if (strokeStart) this.strokes.push(this.state.brushes.length);
    this.dropSigmaFileRef();
    this.state.brushes.push(b);
    const range = this.surface.colorRange;
    this.surface.addBrush(b);
    if (this.surface.colorRange !== range) this.updateSigmaBar();
    this.edits.stamped(eventTime);
    this.viewport?.interacting();
    this.sigmaSync.push();
  }

  /** Whole-σ changes (preset, base, reset, undo). */
  private sigmaEdited(save: boolean): void {
    this.dropSigmaFileRef();
    this.surface?.setSigma(this.sigmaBody());
    this.updateSigmaBar();
    this.updateHistogram();
    this.edits.edited(performance.now());
    this.viewport?.invalidate();
    this.sigmaSync.push();
    if (save) this.save();
  }

  private sigmaApplied(version: number): void {
    this.sigmaVersion = Math.max(this.sigmaVersion, version);
    this.viewport?.invalidate();
    this.slice?.refresh();
  }

  private allShownAtLeast(version: number): boolean {
    const shown = this.iso.shown();
    return this.state.levels.every((l) => shown.some((s) => s.level === l && s.sigma_version >= version));
  }

  private beforeRender(): void {
    this.edits.beforeRender((version) => this.allShownAtLeast(version));
    // The slice follows σ: resample when it shows an older σ than the current one.
    if (this.slice && this.state.slice.show && this.sliceAtVersion !== this.sigmaVersion && this.slice.lastSigmaVersion >= 0) {
      this.sliceAtVersion = this.sigmaVersion;
      this.slice.refresh();
    }
    if (this.hoverEvent) this.hover(this.hoverEvent);
    this.hoverEvent = null;
  }

  private afterRender(renderMs: number): void {
    this.edits.afterRender(renderMs, this.status?.stats?.n_verts ?? 0, this.state.lx);
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
    this.updateIsoLegend();
    this.save();
    const id = this.objectId;
    if (id)
      void api.put(`/api/kelvin/objects/${id}/levels`, { levels: this.state.levels }).then(
        () => dismissToasts("kelvin:levels"),
        (e) => showError(e, "levels", "kelvin:levels"),
      );
    this.viewport?.invalidate();
  }

  private sliceChanged(): void {
    const s = this.state.slice;
    this.slice?.configure(s.axis, s.offset, s.show);
    this.updateHBar();
    this.save();
    this.viewport?.invalidate();
  }

  private restyle(): void {
    this.iso.setVisible(this.state.showIso);
    this.iso.setOpacity(this.state.opacity);
    this.updateIsoLegend();
    if (this.brush) {
      this.brush.enabled = this.state.brush.on;
      this.brush.settings = { value: this.state.brush.value, radius: this.state.brush.radius, falloff: this.state.brush.falloff };
    }
    this.surface?.setColor(this.state.sigmaColor);
    this.updateSigmaBar();
    this.save();
    this.viewport?.invalidate();
  }

  private sliceStyleChanged(): void {
    this.slice?.setColor(this.state.sliceColor);
    this.updateHBar();
    this.save();
    this.viewport?.invalidate();
  }

  /** The colour bars follow what is coloured: σ's map and range, the slice's while it is shown. */
  private updateSigmaBar(): void {
    const s = this.surface;
    if (!this.sigmaBar) return;
    this.sigmaBar.visible = s !== null;
    if (s) this.sigmaBar.update(this.state.sigmaColor, s.colorRange, Number.isFinite(s.dataRange[0]) ? s.dataRange : null);
  }

  private updateHBar(): void {
    const sl = this.slice;
    if (!this.hBar || !sl) return;
    this.hBar.visible = sl.shown;
    if (sl.shown) this.hBar.update(this.state.sliceColor, sl.colorRange, sl.dataRange);
  }

  /** The shells' legend: each watched level with its colour, while the shells are shown. */
  private updateIsoLegend(): void {
    this.isoLegend?.update(this.iso, this.state.levels, this.state.showIso, this.loads > 0 || this.objectId !== null);
  }

  /** Once per stroke or σ change, not per stamp (the picture's colours follow every stamp). */
  private updateHistogram(): void {
    if (this.surface) this.histogram?.update(this.surface.sigmaValues());
  }

  private hover(ev: PointerEvent): void {
    const vp = this.viewport;
    if (!vp || !this.probe || this.brush?.isPainting || ev.buttons !== 0) return;
    const r = vp.renderer.domElement.getBoundingClientRect();
    const ray = new THREE.Raycaster();
    ray.setFromCamera(new THREE.Vector2(((ev.clientX - r.left) / r.width) * 2 - 1, -((ev.clientY - r.top) / r.height) * 2 + 1), vp.camera);
    // The nearest of the slice and the object's surface (raycast on its input mesh), seen through
    // the translucent shells; a shell where the pointer meets neither.
    const targets: THREE.Object3D[] = [];
    if (this.slice?.plane.visible) targets.push(this.slice.plane);
    if (this.state.showIso) targets.push(...this.iso.meshes());
    if (this.surface) targets.push(this.surface.pickMesh);
    const hits = ray.intersectObjects(targets, false);
    const hit = hits.find((h) => this.iso.levelOf(h.object) === null) ?? hits[0];
    if (!hit) return;
    if (this.surface && hit.object === this.surface.pickMesh) {
      // h is defined outside the object: query a hair outside (on the surface itself h = σ, eq. 9).
      const p = hit.point.clone();
      if (hit.face) p.addScaledVector(hit.face.normal, 1e-4 * this.surface.bounds.getSize(new THREE.Vector3()).length());
      this.probe.at(p, { on: "surface", sigma: evaluateAt(this.sigmaBody(), [hit.point.x, hit.point.y, hit.point.z]) });
    } else if (this.slice && hit.object === this.slice.plane) this.probe.at(hit.point, { on: "slice" });
    else this.probe.at(hit.point, { on: `iso-surface h = ${this.iso.levelOf(hit.object) ?? "?"}` });
  }

  private async exportShown(): Promise<void> {
    const id = this.objectId;
    if (!id) return void toast("no object yet", "info");
    const name = this.state.object === "upload" ? this.objectName().replace(/\.[^.]+$/, "") : this.state.object; // the file's stem
    await downloadIsoSurfaces(id, name, this.state.levels, this.state.format);
  }

  // ---- σ files ----
  private saveSigma(): void {
    const s = this.state;
    const mesh = s.object === "upload" ? { upload: this.objectName() } : { asset: s.object };
    const text = sigmaFileText({ mesh, lx: s.lx, preset: s.preset, base: s.base, brushes: s.brushes }, this.sigmaBody());
    const a = document.createElement("a");
    a.href = URL.createObjectURL(new Blob([text], { type: "application/json" }));
    a.download = `${this.objectName().replace(/\.[^.]+$/, "")}-sigma.json`;
    a.click();
    window.setTimeout(() => URL.revokeObjectURL(a.href), 2000);
  }

  private async loadSigma(file: File): Promise<void> {
    let c;
    try {
      c = parseSigmaFile(await file.text());
      if ("asset" in c.mesh && !this.assets.includes(c.mesh.asset)) throw new SigmaFileError("mesh.asset", `no built-in object "${c.mesh.asset}" (${this.assets.join(", ")})`);
      if ("upload" in c.mesh && (this.state.object !== "upload" || this.objectName() !== c.mesh.upload))
        throw new SigmaFileError("mesh.upload", `this σ is for the uploaded ${c.mesh.upload}: upload it first`);
    } catch (e) {
      showError(e, `cannot load σ from ${file.name}`);
      return;
    }
    const want = this.state.sigmaFile;
    if (want && (c.brushes.length !== want.stamps || (await brushesDigest(c.brushes)) !== want.digest))
      toast(`${file.name} is not the σ file the link refers to (${want.stamps} stamps): loaded anyway`, "info", 6000);
    const s = this.state;
    const object = "asset" in c.mesh ? c.mesh.asset : "upload";
    const reload = object !== s.object || (c.lx !== undefined && c.lx !== s.lx);
    if (object !== s.object) s.brush.radius = 0;
    s.lx = c.lx ?? (object !== s.object ? (defaultLx[object] ?? s.lx) : s.lx);
    s.object = object;
    s.preset = c.preset;
    s.base = c.base;
    s.brushes = c.brushes;
    this.strokes = [];
    this.panel?.refresh();
    if (reload) {
      this.dropSigmaFileRef();
      void this.load();
    } else this.sigmaEdited(true);
    toast(`σ from ${file.name}: ${c.brushes.length} brush stamps`, "ok");
  }

  private dropSigmaFileRef(): void {
    if (!this.state.sigmaFile) return;
    this.state.sigmaFile = undefined;
    this.showSigmaNotice();
  }

  private showSigmaNotice(): void {
    const ref = this.state.sigmaFile,
      el = this.panel?.sigmaNotice;
    if (!el) return;
    el.hidden = !ref;
    if (ref) el.textContent = `This link's σ has ${ref.stamps} brush stamps, too many for a link: load its σ file (saved with "save σ file…").`;
  }

  // ---- bookkeeping ----
  private save(): void {
    this.host.saveState(writeStateJson(this.state), this.shrinkLink);
  }

  /** Too many brush stamps for a link: it refers to the σ file instead (saved by the user). */
  private readonly shrinkLink = async (json: Record<string, unknown>): Promise<Record<string, unknown>> => {
    const rest = { ...json };
    delete rest.brushes;
    if (!this.longLinkTold)
      toast(`σ has ${this.state.brushes.length} brush stamps, too many for a link: the link refers to its σ file (save it with "save σ file…")`, "info", 8000);
    this.longLinkTold = true;
    return { ...rest, sigmaFile: { stamps: this.state.brushes.length, digest: await brushesDigest(this.state.brushes) } };
  };

  /** The link of the view as it is now (not the address bar's, written 150 ms after a change): an
   *  upload by its digest, name and size, with its repair options, as any upload. */
  private async copyLink(): Promise<void> {
    const href = location.href.split("#")[0] + (await linkFor("kelvin", writeStateJson(this.state), this.shrinkLink));
    await navigator.clipboard?.writeText(href);
    toast("link copied", "ok");
  }

  /** The object's name as shown: the uploaded file's, or the asset's. */
  private objectName(): string {
    if (this.state.object !== "upload") return this.state.object;
    return this.upload && "name" in this.upload ? this.upload.name : (this.state.upload?.name ?? "the uploaded mesh");
  }

  /** Estimates by request (a few dozen: a session's l_x and repair choices). */
  private rememberEstimate(key: string, est: Estimate): void {
    this.estimates.delete(key);
    this.estimates.set(key, est);
    if (this.estimates.size > 64) this.estimates.delete(this.estimates.keys().next().value as string);
  }

  private updateStats(): void {
    const st = this.status?.stats ?? {};
    const name = this.objectName();
    this.panel?.setStats(statsRows(name, this.state.lx, st, this.surface?.inputVertices, this.timings.prepareMs.at(-1), this.estimateShown));
    this.host.status(statusLine(name, st));
  }

  unmount(): void {
    this.ticket++;
    void this.job?.cancel();
    this.sigmaSync.cancelPending();
    this.surfaces.reset();
    this.offs.forEach((f) => f());
    this.offs = [];
    this.brush?.dispose();
    this.probe?.dispose();
    this.slice?.dispose();
    this.sigmaBar?.dispose();
    this.hBar?.dispose();
    this.isoLegend?.dispose();
    this.histogram?.dispose();
    this.panel?.dispose();
    this.notice?.dispose();
    this.dropDefects();
    this.dropSurface();
    this.dropOverlay();
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
      { key: "f", description: "frame the object", run: () => this.frameObject() },
    ];
  }

  screenshot(): Promise<Blob> {
    if (!this.viewport) return Promise.reject(new Error("no view"));
    return this.viewport.screenshot();
  }
}
