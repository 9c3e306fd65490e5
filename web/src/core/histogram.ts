// A histogram of a scalar over a surface (σ over the Kelvin object), drawn with uPlot as bars:
// how much of the surface has each value, with the value's unit on the x axis.
import uPlot from "uplot";
import "uplot/dist/uPlot.min.css";
import { finiteRange } from "./colormap";

export interface HistogramData {
  /** Bin edges (bins + 1 values) and the share of samples in each bin. */
  edges: number[];
  counts: number[];
  total: number;
}

/** Equal-width bins over the data's range (one bin around a constant). */
export function histogram(values: ArrayLike<number>, bins: number): HistogramData {
  let [lo, hi] = finiteRange(values);
  if (!Number.isFinite(lo)) return { edges: [], counts: [], total: 0 };
  if (!(hi > lo)) [lo, hi] = [lo - 0.5, hi + 0.5];
  const w = (hi - lo) / bins;
  const counts = new Array<number>(bins).fill(0);
  let total = 0;
  for (let i = 0; i < values.length; i++) {
    const v = values[i];
    if (!Number.isFinite(v)) continue;
    counts[Math.min(bins - 1, Math.floor((v - lo) / w))]++;
    total++;
  }
  return { edges: Array.from({ length: bins + 1 }, (_, k) => lo + k * w), counts, total };
}

const AXIS = { stroke: "#8b949e", grid: { stroke: "#2c323a", width: 1 }, ticks: { stroke: "#2c323a", width: 1 } };

export class HistogramPlot {
  private plot: uPlot;
  data: HistogramData = { edges: [], counts: [], total: 0 };

  constructor(
    private readonly root: HTMLElement,
    xLabel: string,
    yLabel: string,
  ) {
    const caption = document.createElement("div");
    caption.className = "histogram-caption";
    caption.textContent = `histogram: ${yLabel} per bin of ${xLabel}`;
    root.appendChild(caption);
    this.plot = new uPlot(
      {
        width: Math.max(200, root.clientWidth || 280),
        height: 150,
        legend: { show: false },
        cursor: { show: false },
        scales: { x: { time: false } },
        axes: [
          { ...AXIS, label: xLabel, labelSize: 18, size: 34 },
          { ...AXIS, label: yLabel, labelSize: 18, size: 44 },
        ],
        series: [{}, { stroke: "#4fa3ff", fill: "rgba(79, 163, 255, 0.45)", paths: uPlot.paths.bars!({ size: [1, Infinity], align: 1 }), points: { show: false } }],
      },
      [[], []],
      root,
    );
  }

  /** Shows the values' histogram, in % of the samples per bin. */
  update(values: ArrayLike<number>, bins = 40): void {
    const h = (this.data = histogram(values, bins));
    const share = h.counts.map((c) => (100 * c) / Math.max(1, h.total));
    this.plot.setData([h.edges.slice(0, -1), share] as uPlot.AlignedData);
  }

  dispose(): void {
    this.plot.destroy();
    this.root.replaceChildren();
  }
}
