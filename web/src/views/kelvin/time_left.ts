/** The time left of a Kelvin preparation (issue 38 goal 3). The job's fraction is the share of its
 *  predicted time done (the server weighs its stages by their predicted seconds), so the time left
 *  is the prediction scaled by the pace of the part done, counted down while a stage runs without
 *  reports (Mesh_3 reports at 10 % and 90 % of the meshing only). */
export class TimeLeft {
  private start: number | null = null;
  private last = 0;
  private pace = 1;

  /** predicted: the estimate's seconds (null: not predicted; then from the pace alone). */
  constructor(
    public predicted: number | null,
    private readonly now = () => performance.now() / 1000,
  ) {}

  /** The job's report (stage, overall fraction); the seconds left now, or null while unknown
   *  (a repair's own fraction, or too little done to judge the pace without a prediction). */
  report(stage: string, fraction: number): number | null {
    if (stage === "repair" || stage === "simplify" || stage === "queued") return null;
    const t = this.now();
    this.start ??= t;
    if (fraction !== this.last && fraction >= 0.05) this.pace = (t - this.start) / (fraction * (this.predicted ?? 1));
    this.last = fraction;
    return this.left();
  }

  /** The seconds left now (the count-down between reports). */
  left(): number | null {
    if (this.start === null) return null;
    const elapsed = this.now() - this.start;
    if (this.predicted === null) return this.last >= 0.05 ? Math.max(0, this.pace - elapsed) : null;
    return Math.max(0, this.pace * this.predicted - elapsed);
  }
}

/** "≈ 12 s left", or what is known. */
export function timeLeftText(seconds: number | null): string {
  if (seconds === null) return "";
  if (seconds < 0.5) return "longer than predicted";
  return `≈ ${seconds < 10 ? seconds.toFixed(1) : String(Math.round(seconds))} s left`;
}
