// The timeline over the 3D view: play / pause, a slider over the steps computed so far (it grows
// while frames stream in), the time, and the playback speed. Playback advances by wall time ×
// speed on animation frames; the view draws whatever step `onStep` reports.
import { SPEEDS } from "./state";

export class Timeline {
  readonly root: HTMLDivElement;
  private readonly play: HTMLButtonElement;
  private readonly slider: HTMLInputElement;
  private readonly time: HTMLSpanElement;
  private readonly speedSel: HTMLSelectElement;
  private readonly fill: HTMLDivElement;
  private raf = 0;
  private last = 0;
  private exact = 0; // fractional step while playing
  step = 0;
  /** Steps available to play (the contiguous prefix of every shown rollout). */
  length = 0;
  total = 0;
  dt = 0.01;
  playing = false;
  speed = 1;

  constructor(
    container: HTMLElement,
    private readonly onStep: (step: number, source: "play" | "user") => void,
    private readonly onSpeed: (speed: number) => void,
  ) {
    this.root = document.createElement("div");
    this.root.className = "cbf-timeline";
    this.play = document.createElement("button");
    this.play.className = "cbf-play";
    this.play.title = "play / pause (Space)";
    this.play.dataset.testid = "cbf-play";
    this.play.addEventListener("click", () => this.toggle());
    const track = document.createElement("div");
    track.className = "cbf-track";
    this.fill = document.createElement("div");
    this.fill.className = "cbf-track-fill"; // how much of the rollout is computed
    this.slider = document.createElement("input");
    this.slider.type = "range";
    this.slider.min = "0";
    this.slider.step = "1";
    this.slider.dataset.testid = "cbf-slider";
    this.slider.setAttribute("aria-label", "time");
    this.slider.addEventListener("input", () => {
      const v = Number(this.slider.value); // read first: pause() re-renders the slider
      this.pause();
      this.seek(v, "user");
    });
    this.slider.addEventListener("change", () => this.slider.blur()); // keep Space / arrows for the view
    track.append(this.fill, this.slider);
    this.time = document.createElement("span");
    this.time.className = "cbf-time";
    this.speedSel = document.createElement("select");
    this.speedSel.title = "playback speed";
    for (const s of SPEEDS) this.speedSel.add(new Option(`${s}×`, String(s)));
    this.speedSel.addEventListener("change", () => {
      this.speed = Number(this.speedSel.value);
      this.onSpeed(this.speed);
      this.speedSel.blur();
    });
    this.root.append(this.play, track, this.time, this.speedSel);
    container.appendChild(this.root);
    this.render();
  }

  setSpeed(s: number): void {
    this.speed = s;
    if (!SPEEDS.includes(s as (typeof SPEEDS)[number])) this.speedSel.add(new Option(`${s}×`, String(s)));
    this.speedSel.value = String(s);
  }

  /** New extent of playable steps (grows as frames arrive). */
  setLength(length: number, total: number, dt: number): void {
    this.length = length;
    this.total = Math.max(total, length);
    this.dt = dt;
    if (this.step >= length) this.step = Math.max(0, length - 1);
    this.render();
  }

  seek(step: number, source: "play" | "user" = "user"): void {
    const s = Math.max(0, Math.min(Math.max(0, this.length - 1), Math.round(step)));
    this.exact = s;
    if (s === this.step && source === "play") return;
    this.step = s;
    this.render();
    this.onStep(s, source);
  }

  toggle(): void {
    if (this.playing) this.pause();
    else this.start();
  }

  start(): void {
    if (this.length < 2) return;
    if (this.step >= this.length - 1) this.seek(0, "user"); // replay from the start
    this.playing = true;
    this.exact = this.step;
    this.last = performance.now();
    cancelAnimationFrame(this.raf);
    const tick = (now: number) => {
      if (!this.playing) return;
      this.raf = requestAnimationFrame(tick);
      const dtWall = Math.min(0.25, (now - this.last) / 1000);
      this.last = now;
      this.exact = Math.min(this.length - 1, this.exact + (dtWall * this.speed) / this.dt);
      const s = Math.floor(this.exact);
      if (s !== this.step) {
        this.step = s;
        this.render();
        this.onStep(s, "play");
      }
      // At the end of what exists: stop, unless more is being computed (then wait for it).
      if (this.exact >= this.length - 1 && this.length >= this.total) this.pause();
    };
    this.raf = requestAnimationFrame(tick);
    this.render();
  }

  pause(): void {
    this.playing = false;
    cancelAnimationFrame(this.raf);
    this.render();
  }

  private render(): void {
    this.play.textContent = this.playing ? "❚❚" : "▶";
    this.play.setAttribute("aria-label", this.playing ? "pause" : "play");
    this.slider.max = String(Math.max(0, this.length - 1));
    this.slider.value = String(this.step);
    this.slider.disabled = this.length === 0;
    // The slider spans what is computed; the bar behind it shows the share of the whole run.
    this.slider.style.width = this.total > 0 ? `${(100 * Math.max(1, this.length)) / this.total}%` : "100%";
    this.fill.style.width = this.slider.style.width;
    const t = this.length ? this.step * this.dt : 0;
    const end = this.total * this.dt;
    this.time.textContent = this.length ? `t = ${t.toFixed(2)} s / ${end.toFixed(2)} s · step ${this.step}` : "no rollout";
  }

  dispose(): void {
    this.pause();
    this.root.remove();
  }
}
