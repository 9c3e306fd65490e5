// The legend of the iso-surface shells (IsoLayers): one row per watched level of h with the
// colour and opacity its shell is drawn in, beside the colour bars; a level whose shell has not
// arrived yet says so. Hidden while the shells are.
import type { IsoLayers } from "./iso_layers";

export interface IsoLegendRow {
  level: number;
  /** "#rrggbb" of the shell's material. */
  color: string;
  opacity: number;
  /** The shell is drawn (its frame arrived). */
  shown: boolean;
}

const fmt = (x: number) => String(Number(x.toPrecision(4)));

export class IsoLegend {
  readonly el: HTMLDivElement;
  private readonly rowsEl: HTMLDivElement;
  rows: IsoLegendRow[] = [];

  constructor(
    parent: HTMLElement,
    title: string,
    private readonly describe: (level: number) => string = () => "",
  ) {
    this.el = document.createElement("div");
    this.el.className = "colorbar iso-legend";
    this.el.dataset.testid = "iso-legend";
    const head = document.createElement("div");
    head.textContent = title;
    this.rowsEl = document.createElement("div");
    this.el.append(head, this.rowsEl);
    this.el.hidden = true;
    // In the row of colour bars when there is one (colorbar.ts), else over the view's corner.
    (parent.querySelector<HTMLElement>(":scope > .colorbars") ?? parent).appendChild(this.el);
  }

  /** The shells' levels, colours and opacities as drawn now; `visible`: the shells are shown;
   *  `coming`: a field is prepared or being prepared, so a missing shell is on its way (else it
   *  never comes: nothing is prepared, e.g. a refused l_x or an upload waiting for its repair). */
  update(iso: IsoLayers, levels: number[], visible: boolean, coming = true): void {
    const drawn = new Set(iso.shown().map((s) => s.level));
    this.rows = [...levels]
      .sort((a, b) => a - b)
      .map((level) => ({ level, color: `#${iso.colorOf(level).getHexString()}`, opacity: iso.opacityOf(level), shown: drawn.has(level) }));
    this.el.hidden = !visible || this.rows.length === 0;
    this.rowsEl.replaceChildren(
      ...this.rows.map((r) => {
        const row = document.createElement("div");
        row.className = "iso-legend-row";
        row.style.cssText = "display: flex; align-items: center; gap: 6px; margin-top: 3px;";
        row.dataset.level = String(r.level);
        const swatch = document.createElement("span");
        swatch.className = "iso-legend-swatch";
        swatch.style.cssText = "display: inline-block; width: 16px; height: 10px; border-radius: 2px;";
        swatch.style.background = r.color;
        swatch.style.opacity = String(Math.max(0.35, Math.min(1, 2 * r.opacity))); // a faint shell stays visible here
        const text = document.createElement("span");
        const note = this.describe(r.level);
        text.textContent = `h = ${fmt(r.level)}${note ? ` ${note}` : ""}${r.shown ? "" : coming ? " (computing…)" : " (no field prepared)"}`;
        row.append(swatch, text);
        return row;
      }),
    );
  }

  dispose(): void {
    this.el.remove();
  }
}
