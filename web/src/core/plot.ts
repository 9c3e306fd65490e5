// A small typed wrapper around uPlot for plots over one x axis: named series (lines, bars, or a
// level per x) on one or two y scales, a vertical marker (current position / time), the values
// under the cursor (in the legend, or beside the cursor when the legend is kept short), a mark on
// curves that no longer match the input (a refused request), and a size that follows its
// container. Used by the GAP sweep and the CBF rollout plots.
import uPlot from "uplot";
import "uplot/dist/uPlot.min.css";

export interface PlotSeries {
  label: string;
  color: string;
  /** "y" (left axis, default) or "y2" (right axis). */
  scale?: "y" | "y2";
  dash?: number[];
  width?: number;
  /** Drawn initially (default true); the legend toggles it. */
  show?: boolean;
  /** "line" (default); "bars": a bar per x from the bottom of the scale; "levels": a horizontal
   *  segment one x unit wide centred on each x (e.g. a threshold per category). */
  kind?: "line" | "bars" | "levels";
  /** Bars: centred on x (0), or left (-1) / right (1) of it, for two bars per x. */
  align?: -1 | 0 | 1;
}

export interface PlotOptions {
  title?: string;
  /** One sentence under the plot saying what each curve is. */
  caption: string;
  /** Axis labels carry their unit, e.g. "t (s)". */
  xLabel: string;
  yLabel?: string;
  /** Label of the right axis; only drawn when a series uses scale "y2". */
  y2Label?: string;
  series: PlotSeries[];
  /** Digits shown in the legend. */
  digits?: number;
  /** Values under the cursor in the legend (default true; false keeps a many-series legend short
   *  and shows them in a box beside the cursor instead). */
  legendValues?: boolean;
  /** Logarithmic left axis (values ≤ 0 are not drawn). */
  yLog?: boolean;
  /** Logarithmic x axis (x must be positive). */
  xLog?: boolean;
  /** x is a category index 0 … n−1: integer ticks, half a unit of room at either end, and the
   *  legend shows the category's name under the cursor. */
  categories?: (i: number) => string;
}

/** Log-scale range; without any positive value a fixed decade (uPlot would fail to draw the axis). */
const logRange: uPlot.Range.Function = (_u, min, max) => (min !== null && max !== null && min > 0 && max > 0 ? uPlot.rangeLog(min, max, 10, true) : [0.01, 1]);

/** A log x range from the data's ends to the 1…9 × 10^k steps around them (uPlot's rangeLog rounds
 *  the top up to a power of ten: 1e-4 … 2e-3 became 1e-4 … 1e-2, the data in half the axis). */
const xLogRange: uPlot.Range.Function = (_u, min, max) => {
  if (min === null || max === null || !(min > 0) || !(max > 0)) return [0.01, 1];
  const step = (v: number) => 10 ** Math.floor(Math.log10(v));
  const round = (v: number) => Number(v.toPrecision(12));
  return [round(Math.floor(min / step(min)) * step(min)), round(Math.ceil(max / step(max)) * step(max))];
};

const AXIS = { stroke: "#8b949e", grid: { stroke: "#2c323a", width: 1 }, ticks: { stroke: "#2c323a", width: 1 } };
/** Log-axis tick labels: below 0.001 as powers of ten (uPlot's own labels would round 1e-4 to "0"). */
const logTicks: uPlot.Axis.Values = (_u, splits) => splits.map((v) => (v === null || v === undefined ? "" : v >= 1e-3 ? String(Number(v.toPrecision(3))) : v.toExponential(0)));
/** The strip's plots are short: tick labels every 18 px (uPlot's 30 leaves one label, no scale). */
const Y_TICKS = { space: 18, font: "10px system-ui, sans-serif" };

/** A path builder that also reports how many bars or segments it drew (into counted[i]). */
function counting(kind: "bars" | "levels", align: -1 | 0 | 1, counted: number[], i: number): uPlot.Series.PathBuilder {
  let n = 0;
  const bars = uPlot.paths.bars!({ size: [align === 0 ? 0.7 : 0.4, 40], align, each: () => n++ });
  const levels: uPlot.Series.PathBuilder = (u, si, i0, i1) => {
    const stroke = new Path2D();
    const xs = u.data[0],
      ys = u.data[si];
    for (let k = i0; k <= i1; k++) {
      const y = ys[k];
      if (y === null || y === undefined) continue;
      const py = u.valToPos(y, u.series[si].scale ?? "y", true);
      stroke.moveTo(u.valToPos(xs[k] - 0.5, "x", true), py);
      stroke.lineTo(u.valToPos(xs[k] + 0.5, "x", true), py);
      n++;
    }
    return { stroke, fill: null, clip: null };
  };
  // uPlot builds paths when data or size change and reuses them on other redraws: the count holds.
  return (u, si, i0, i1) => {
    n = 0;
    const paths = kind === "bars" ? bars(u, si, i0, i1) : levels(u, si, i0, i1);
    counted[i] = n;
    return paths;
  };
}

/** Every plot on the page, for the test hook window.distlab.plots(). */
const live = new Set<Plot>();

/** What a reader sees of each plot on the page: title, axes (label, tick labels), legend, caption. */
function describePlots() {
  return [...live]
    .filter((p) => p.root.isConnected)
    .map((p) => ({
      title: p.root.querySelector(".u-title")?.textContent ?? "",
      axes: p.axes(),
      legend: [...p.root.querySelectorAll(".u-legend .u-series th")].map((e) => e.textContent ?? "").filter((t) => t),
      caption: p.root.querySelector(".plot-caption")?.textContent ?? "",
      stale: p.stale,
    }));
}

export class Plot {
  readonly root: HTMLDivElement;
  private readonly u: uPlot;
  private marker: number | null = null;
  private readonly observer: ResizeObserver;
  private xs: number[] = [];
  private ys: Array<Array<number | null>> = [];
  /** Per series: bars or level segments in the last drawing (lines: 0). */
  private readonly counted: number[];
  /** The mark over curves that are not those of the current input (null: current). */
  private readonly staleEl: HTMLDivElement;
  private staleText: string | null = null;
  /** The values under the cursor when the legend does not show them. */
  private tip: HTMLDivElement | null = null;

  constructor(
    container: HTMLElement,
    readonly options: PlotOptions,
  ) {
    this.root = document.createElement("div");
    this.root.className = "plot";
    this.root.style.cssText = "flex: 1; min-width: 0; min-height: 0; position: relative;";
    container.appendChild(this.root);
    this.root.setAttribute("role", "figure");
    this.counted = options.series.map(() => 0);
    const digits = options.digits ?? 4;
    const fmt = (_u: uPlot, v: number | null) => (v === null || v === undefined ? "—" : v.toFixed(digits));
    const usesY2 = options.series.some((s) => s.scale === "y2");
    const cat = options.categories;
    const xAxis: uPlot.Axis = cat
      ? { incrs: [1, 2, 5, 10, 20, 50, 100, 200, 500], values: (_u, splits) => splits.map((v) => (Number.isInteger(v) ? String(v) : "")) }
      : options.xLog
        ? { values: logTicks, space: 24 } // a strip's plot may be 60 px wide: still a label per decade
        : {};
    const axes: uPlot.Axis[] = [
      { ...AXIS, ...xAxis, label: options.xLabel },
      { ...AXIS, ...Y_TICKS, label: options.yLabel ?? "", scale: "y", ...(options.yLog ? { values: logTicks } : {}) },
    ];
    if (usesY2) axes.push({ ...AXIS, ...Y_TICKS, label: options.y2Label ?? "", scale: "y2", side: 1, grid: { show: false } });
    const opts: uPlot.Options = {
      title: options.title,
      width: 400,
      height: 200,
      scales: {
        x: cat
          ? { time: false, range: (_u, min, max) => (min === null || max === null ? [-0.5, 0.5] : [min - 0.5, max + 0.5]) }
          : options.xLog
            ? { time: false, distr: 3, range: xLogRange }
            : { time: false },
        y: options.yLog ? { distr: 3, auto: true, range: logRange } : { auto: true },
        ...(usesY2 ? { y2: { auto: true } } : {}),
      },
      axes,
      series: [
        { label: options.xLabel, value: cat ? (_u: uPlot, v: number | null) => (v === null || v === undefined ? "—" : cat(Math.round(v))) : fmt },
        ...options.series.map((s, i) => ({
          label: s.label,
          stroke: s.color,
          fill: s.kind === "bars" ? `${s.color}b0` : undefined,
          width: s.width ?? 1.5,
          dash: s.dash,
          scale: s.scale ?? "y",
          show: s.show ?? true,
          value: fmt,
          points: { show: false },
          paths: s.kind === "bars" || s.kind === "levels" ? counting(s.kind, s.align ?? 0, this.counted, i) : undefined,
        })),
      ],
      legend: { live: options.legendValues ?? true },
      cursor: { drag: { x: false, y: false } },
      hooks: { draw: [(u) => this.drawMarker(u)], ...(options.legendValues === false ? { setCursor: [(u: uPlot) => this.showCursorValues(u)] } : {}) },
    };
    this.u = new uPlot(opts, [[], ...options.series.map(() => [])], this.root);
    const caption = document.createElement("p");
    caption.className = "plot-caption";
    caption.style.cssText = "margin: 0 4px 2px; font-size: 10px; line-height: 1.25; color: var(--muted);";
    caption.textContent = options.caption;
    this.root.appendChild(caption);
    this.staleEl = document.createElement("div");
    this.staleEl.className = "plot-stale";
    this.staleEl.style.cssText =
      "position: absolute; inset: 0; align-items: center; justify-content: center; padding: 4px 12px; text-align: center; font-size: 12px; color: var(--bad, #ff6b6b); background: rgba(23, 26, 31, 0.72); pointer-events: none;";
    this.staleEl.setAttribute("role", "status");
    this.staleEl.hidden = true;
    this.staleEl.style.display = "none"; // an inline display would override [hidden]
    this.u.over.appendChild(this.staleEl);
    if (options.legendValues === false) {
      this.tip = document.createElement("div");
      this.tip.className = "plot-cursor-values";
      this.tip.style.cssText =
        "position: absolute; top: 4px; padding: 3px 6px; font-size: 10px; line-height: 1.3; white-space: nowrap; background: rgba(29, 33, 39, 0.92); border-radius: 4px; pointer-events: none; z-index: 1;";
      this.tip.hidden = true;
      this.u.over.appendChild(this.tip);
    }
    this.describe();
    live.add(this);
    const w = window as unknown as { distlab?: Record<string, unknown> };
    w.distlab = Object.assign(w.distlab ?? {}, { plots: describePlots });
    this.observer = new ResizeObserver(() => this.resize());
    this.observer.observe(this.root);
  }

  /** Replaces the data: one x array and one y array per series (null = gap in the line). */
  setData(x: ArrayLike<number>, ys: Array<ArrayLike<number | null>>): void {
    if (ys.length !== this.options.series.length) throw new Error("plot: one y array per series");
    this.xs = Array.from(x);
    this.ys = ys.map((y) => {
      if (y.length !== this.xs.length) throw new Error("plot: series length differs from x");
      return Array.from(y, (v) => (v === null || Number.isFinite(v) ? v : null));
    });
    this.u.setData([this.xs, ...this.ys] as uPlot.AlignedData);
  }

  /** Marks the curves as not matching the current input (e.g. after a refused request): dimmed,
   *  with the reason over them; null: they are current again. */
  setStale(reason: string | null): void {
    this.staleText = reason;
    this.staleEl.textContent = reason ? `not updated — ${reason}` : "";
    this.staleEl.hidden = !reason;
    this.staleEl.style.display = reason ? "flex" : "none";
    this.root.classList.toggle("stale", Boolean(reason));
  }

  get stale(): string | null {
    return this.staleText;
  }

  /** The values under the cursor beside it (plots whose legend lists only the names). */
  private showCursorValues(u: uPlot): void {
    const tip = this.tip;
    if (!tip) return;
    const i = u.cursor.idx;
    if (i === null || i === undefined || u.cursor.left === undefined || u.cursor.left < 0) return void (tip.hidden = true);
    const digits = this.options.digits ?? 4;
    const x = this.xs[i];
    const rows: HTMLDivElement[] = [];
    const head = document.createElement("div");
    head.textContent = `${this.options.xLabel} = ${this.options.categories ? this.options.categories(Math.round(x)) : Number(x.toPrecision(6))}`;
    rows.push(head);
    this.options.series.forEach((s, k) => {
      const v = this.ys[k]?.[i];
      if (!u.series[k + 1].show || v === null || v === undefined) return;
      const row = document.createElement("div");
      row.style.color = s.color;
      row.textContent = `${s.label}: ${v.toFixed(digits)}`;
      rows.push(row);
    });
    tip.replaceChildren(...rows);
    tip.hidden = false;
    // Beside the cursor, on the side with room.
    const left = u.cursor.left;
    const right = left > u.over.clientWidth / 2;
    tip.style.left = right ? "" : `${left + 12}px`;
    tip.style.right = right ? `${u.over.clientWidth - left + 12}px` : "";
  }

  /** What the box beside the cursor shows (null: hidden or none), for tests. */
  cursorValues(): string[] | null {
    if (!this.tip || this.tip.hidden) return null;
    return [...this.tip.children].map((e) => e.textContent ?? "");
  }

  /** A vertical line at x (e.g. the current position); null hides it. */
  setMarker(x: number | null): void {
    if (x === this.marker) return;
    this.marker = x;
    // Before any data uPlot has not laid out its axes: a redraw without recalculation would throw.
    if (this.xs.length > 0) this.u.redraw(false, false);
  }

  /** Shows or hides series i (index into options.series). */
  setShown(i: number, show: boolean): void {
    this.u.setSeries(i + 1, { show });
  }

  /** Calls f with the x value under a click in the plotting area (e.g. to seek to a time). */
  onPick(f: (x: number) => void): void {
    this.u.over.addEventListener("click", (e) => {
      const r = this.u.over.getBoundingClientRect();
      f(this.u.posToVal(e.clientX - r.left, "x"));
    });
  }

  /** Replaces the title line (e.g. to name the current x unit). */
  setTitle(text: string): void {
    const t = this.root.querySelector<HTMLElement>(".u-title");
    if (t) t.textContent = text;
    this.describe();
  }

  /** Relabels an axis (0: x, 1: left y, 2: right y), e.g. when the x unit changes. */
  setAxisLabel(axis: number, label: string): void {
    const a = this.u.axes[axis];
    if (!a || a.label === label) return;
    a.label = label;
    this.describe();
    if (this.xs.length > 0) this.u.redraw(false, true);
  }

  /** The axes as drawn: label and tick labels of each shown axis (for tests). */
  axes(): Array<{ label: string; ticks: string[] }> {
    type Drawn = uPlot.Axis & { _values?: Array<string | number | null> | null };
    return (this.u.axes as Drawn[])
      .filter((a) => a.show !== false)
      .map((a) => ({ label: String(a.label ?? ""), ticks: (a._values ?? []).filter((v) => v !== null && v !== "").map(String) }));
  }

  /** What is plotted (for tests and exports), per series the bars or level segments drawn, the
   *  x axis's distribution (1 linear, 3 log) and why the curves are stale (null: current). */
  data(): { labels: string[]; x: number[]; y: Array<Array<number | null>>; drawn: number[]; xDistr: number; stale: string | null } {
    return {
      labels: this.options.series.map((s) => s.label),
      x: [...this.xs],
      y: this.ys.map((a) => [...a]),
      drawn: [...this.counted],
      xDistr: this.u.scales.x.distr ?? 1,
      stale: this.staleText,
    };
  }

  /** The figure's accessible name: title, axis labels and the caption. */
  private describe(): void {
    const labels = this.u.axes.map((a) => a.label).filter((l) => l);
    this.root.setAttribute(
      "aria-label",
      [this.u.root.querySelector(".u-title")?.textContent ?? "", `axes: ${labels.join("; ")}`, this.options.caption].filter((t) => t).join(". "),
    );
  }

  private drawMarker(u: uPlot): void {
    if (this.marker === null) return;
    const x = u.valToPos(this.marker, "x", true);
    const ctx = u.ctx;
    ctx.save();
    ctx.strokeStyle = "#d8dde3";
    ctx.setLineDash([4, 4]);
    ctx.lineWidth = 1;
    ctx.beginPath();
    ctx.moveTo(x, u.bbox.top);
    ctx.lineTo(x, u.bbox.top + u.bbox.height);
    ctx.stroke();
    ctx.restore();
  }

  private resize(): void {
    const legend = this.root.querySelector<HTMLElement>(".u-legend")?.offsetHeight ?? 0;
    const title = this.root.querySelector<HTMLElement>(".u-title")?.offsetHeight ?? 0;
    const caption = this.root.querySelector<HTMLElement>(".plot-caption")?.offsetHeight ?? 0;
    const w = Math.max(120, this.root.clientWidth);
    const h = Math.max(80, this.root.clientHeight - legend - title - caption);
    if (w !== this.u.width || h !== this.u.height) this.u.setSize({ width: w, height: h });
  }

  dispose(): void {
    live.delete(this);
    this.observer.disconnect();
    this.u.destroy();
    this.root.remove();
  }
}
