// How long a σ edit takes to reach the screen (the timings on window.distlab.kelvin): each edit's
// stages from its first mouse event to the animation frame that draws its iso-surfaces, and each
// mouse event to its σ colours drawn. Kept apart so the view's logic reads without the clocks.
import { socket, type BinaryFrame } from "../../core/socket";
import type { Timings } from "./test_hooks";

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

export class EditTracer {
  private unsentSince: number | null = null; // the first change not sent yet
  private inflight: EditTrace | null = null; // the edit sent and not yet acknowledged
  private inflightTimed = false; // it carries a change (not only a resend)
  // σ version → the stages of its way to the screen, until the frame that draws it.
  private awaitingDraw = new Map<number, EditTrace>();
  private drawing: Array<[number, EditTrace]> = []; // complete in the frame being rendered
  private localPending: number[] = []; // mouse events whose σ colours are not drawn yet

  constructor(private readonly timings: Timings) {}

  /** A brush stamp at a mouse event (its colours are drawn locally at the next frame). */
  stamped(eventTime: number): void {
    this.localPending.push(eventTime);
    this.edited(eventTime);
  }

  /** σ changed at time t (performance.now). */
  edited(t: number): void {
    this.unsentSince ??= t;
  }

  /** σ is sent to the server now: the changes since the last send are on their way. */
  sent(): void {
    const since = this.unsentSince;
    this.unsentSince = null;
    const sent = performance.now();
    this.inflight = { since: since ?? sent, sent, answered: 0, arrived: 0, processed: 0, decodeMs: 0, acceptMs: 0, serverMs: 0, raf: 0 };
    this.inflightTimed = since !== null;
  }

  /** The server's answer to what was sent: its σ version, or null (refused, or the object changed). */
  answered(version: number | null): void {
    const trace = this.inflight;
    this.inflight = null;
    if (!trace || version === null) return;
    trace.answered = performance.now();
    if (this.inflightTimed) this.awaitingDraw.set(version, trace); // drawn at the next frame if its frames came first
  }

  /** An iso-surface frame of σ `version` became a geometry, from t0 on. It completes that σ's
   *  edit, or an older one's that the server skipped for it. */
  frameAccepted(f: BinaryFrame, version: number, currentVersion: number, t0: number): void {
    const traces = [...this.awaitingDraw].filter(([v]) => v <= version).map(([, t]) => t);
    if (this.inflight && version > currentVersion) traces.push(this.inflight);
    const t1 = performance.now();
    for (const trace of traces) {
      trace.arrived = socket.frameArrivedAt;
      trace.decodeMs += t0 - socket.frameArrivedAt;
      trace.acceptMs += t1 - t0;
      trace.processed = t1;
      const server = f.server_ms as { since_edit?: number } | undefined;
      trace.serverMs = Math.max(trace.serverMs, server?.since_edit ?? 0);
    }
  }

  /** An animation frame begins: the edits whose every level is shown are drawn in it. */
  beforeRender(shownAtLeast: (version: number) => boolean): void {
    const now = performance.now();
    for (const [version, t] of this.awaitingDraw)
      if (shownAtLeast(version)) {
        t.raf = now;
        this.drawing.push([version, t]);
        this.awaitingDraw.delete(version);
      }
  }

  /** That frame was rendered (renderMs): record what it drew. */
  afterRender(renderMs: number, fieldVertices: number, lx: number): void {
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
        fieldVertices,
        lx,
      });
    }
    this.drawing = [];
  }
}
