// How long the view takes to draw a step, and how long a streamed frame takes from its arrival to
// the screen (read by window.distlab.cbf.timings(): measured, never asserted).
export class DrawTimings {
  /** Arrival of a followed frame → the end of the render that shows it. */
  readonly arrivalToDrawnMs: number[] = [];
  /** JS time to pose the robots, witnesses, readout and plot cursors. */
  readonly drawMs: number[] = [];
  private pendingArrival: number | null = null;

  /** A frame that arrived at `t` (performance.now()) is shown by the next render. */
  arrived(t: number): void {
    this.pendingArrival ??= t;
  }

  drew(ms: number): void {
    keep(this.drawMs, ms);
  }

  /** Runs before each render of the viewport. */
  beforeRender(): void {
    if (this.pendingArrival === null) return;
    const arrived = this.pendingArrival;
    this.pendingArrival = null;
    // Microtasks run after this animation-frame callback, i.e. after the render call.
    queueMicrotask(() => keep(this.arrivalToDrawnMs, performance.now() - arrived));
  }
}

/** Appends, keeping the last 1000–2000 values. */
function keep(list: number[], v: number): void {
  list.push(v);
  if (list.length > 2000) list.splice(0, 1000);
}
