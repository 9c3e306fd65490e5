// A colour bar beside the 3D view for each colour-mapped quantity: the map's colours over the
// range shown, ticks, the quantity's name and unit, and the data's own range. Also the panel
// controls that choose a quantity's map and range, and the URL form of that choice.
import type GUI from "lil-gui";
import { colorbarTicks, colormapBytes, colormapNames, isDiverging, normalize, rangeModes, type ColorScale } from "./colormap";
import { num, str } from "./urlstate";

export interface ColorBarState {
  title: string;
  unit: string;
  map: string;
  range: [number, number];
  dataRange: [number, number] | null;
  ticks: number[];
  /** Each tick's distance from the bar's bottom, a fraction of its height. */
  tickPositions: number[];
  /** Values marked across the bar (a threshold), and the colour of values below `below.value`. */
  marks: Array<{ value: number; label: string }>;
  below: { value: number; color: string } | null;
}

/** What a bar shows besides its map: marked values, and one colour for values below a threshold
 *  (e.g. h below the barrier's δ, drawn red). */
export interface ColorBarExtras {
  marks?: Array<{ value: number; label: string }>;
  below?: { value: number; color: string };
}

/** "#rrggbb" as RGBA bytes. */
function hexBytes(color: string): number[] {
  const v = parseInt(color.slice(1), 16);
  return [(v >> 16) & 255, (v >> 8) & 255, v & 255, 255];
}

const fmt = (x: number) => (x === 0 ? "0" : Math.abs(x) >= 1e4 || Math.abs(x) < 1e-3 ? x.toExponential(2) : String(Number(x.toPrecision(4))));

/** The column of colour bars at the right of a viewport's container. */
function stackOf(parent: HTMLElement): HTMLElement {
  let s = parent.querySelector<HTMLElement>(":scope > .colorbars");
  if (!s) {
    s = document.createElement("div");
    s.className = "colorbars";
    parent.appendChild(s);
  }
  return s;
}

export class ColorBar {
  readonly el: HTMLDivElement;
  private readonly canvas: HTMLCanvasElement;
  private readonly ticksEl: HTMLDivElement;
  private readonly titleEl: HTMLDivElement;
  private readonly dataEl: HTMLDivElement;
  private current: ColorBarState | null = null;

  constructor(
    parent: HTMLElement,
    private title: string,
    private readonly unit: string,
    testid: string,
  ) {
    this.el = document.createElement("div");
    this.el.className = "colorbar";
    this.el.dataset.testid = testid;
    this.el.hidden = true;
    this.titleEl = document.createElement("div");
    this.titleEl.className = "colorbar-title";
    this.titleEl.textContent = unit ? `${title} (${unit})` : title;
    const body = document.createElement("div");
    body.className = "colorbar-body";
    this.canvas = document.createElement("canvas");
    this.canvas.width = 1;
    this.canvas.height = 256;
    this.ticksEl = document.createElement("div");
    this.ticksEl.className = "colorbar-ticks";
    body.append(this.canvas, this.ticksEl);
    this.dataEl = document.createElement("div");
    this.dataEl.className = "colorbar-data";
    this.el.append(this.titleEl, body, this.dataEl);
    stackOf(parent).appendChild(this.el);
  }

  /** Draws the bar for a scale resolved to `range`; `data` is the quantity's own min and max. */
  update(scale: ColorScale, range: [number, number], data: [number, number] | null, extras: ColorBarExtras = {}): void {
    const [lo, hi] = range;
    const centred = isDiverging(scale.map);
    const lut = colormapBytes(scale.map);
    const below = extras.below ? hexBytes(extras.below.color) : null;
    // Row y (0 = top = hi) shows the colour of the value there, through the same normalisation
    // as the picture (so a centred map's two halves are stretched as they are on screen).
    const img = new ImageData(1, 256);
    for (let y = 0; y < 256; y++) {
      const v = hi - ((hi - lo) * y) / 255;
      if (below && extras.below && v < extras.below.value) {
        img.data.set(below, y * 4);
        continue;
      }
      const k = Math.round(normalize(v, lo, hi, centred) * 255) * 4;
      img.data.set(lut.subarray(k, k + 4), y * 4);
    }
    this.canvas.getContext("2d")!.putImageData(img, 0, 0);
    const ticks = colorbarTicks(lo, hi, centred);
    const pos = ticks.map((t) => (t - lo) / (hi - lo));
    const marks = (extras.marks ?? []).filter((m) => m.value >= lo && m.value <= hi);
    this.ticksEl.replaceChildren(
      ...ticks.map((t, i) => {
        const d = document.createElement("div");
        d.className = "colorbar-tick";
        d.style.bottom = `${(pos[i] * 100).toFixed(2)}%`;
        d.textContent = fmt(t);
        return d;
      }),
      ...marks.map((m) => {
        const d = document.createElement("div");
        d.className = "colorbar-tick colorbar-mark";
        d.style.bottom = `${(((m.value - lo) / (hi - lo)) * 100).toFixed(2)}%`;
        d.textContent = m.label;
        return d;
      }),
    );
    this.dataEl.textContent = data ? `data ${fmt(data[0])} … ${fmt(data[1])}\nshown ${fmt(lo)} … ${fmt(hi)}` : `shown ${fmt(lo)} … ${fmt(hi)}`;
    this.current = { title: this.title, unit: this.unit, map: scale.map, range: [lo, hi], dataRange: data, ticks, tickPositions: pos, marks, below: extras.below ?? null };
  }

  /** Another quantity of the same unit (the GAP slice shows e_S or E_S). */
  retitle(title: string): void {
    this.title = title;
    this.titleEl.textContent = this.unit ? `${title} (${this.unit})` : title;
    if (this.current) this.current.title = title;
  }

  set visible(v: boolean) {
    this.el.hidden = !v;
  }

  get state(): ColorBarState | null {
    return this.el.hidden ? null : this.current;
  }

  dispose(): void {
    const stack = this.el.parentElement;
    this.el.remove();
    if (stack && stack.childElementCount === 0) stack.remove();
  }
}

/** A colour scale from the URL, typed and bounded, with defaults. */
export function readColorScale(v: unknown, d: ColorScale): ColorScale {
  const o = (v && typeof v === "object" ? v : {}) as Record<string, unknown>;
  return { map: str(o.map, colormapNames, d.map), mode: str(o.mode, rangeModes, d.mode), min: num(o.min, d.min, -1e6, 1e6), max: num(o.max, d.max, -1e6, 1e6) };
}

/** Map, range mode and the fixed range's ends in a panel folder; min and max apply in "fixed". */
export function addColorControls(folder: GUI, s: ColorScale, changed: () => void): void {
  folder
    .add(s, "map", [...colormapNames])
    .name("colormap")
    .onChange(changed);
  folder
    .add(s, "mode", [...rangeModes])
    .name("range")
    .onChange(changed);
  folder.add(s, "min").name("fixed min").onFinishChange(changed);
  folder.add(s, "max").name("fixed max").onFinishChange(changed);
}
