// Latest-wins requests paced by the server: at most one request in flight; while it runs, newer
// inputs replace each other and only the newest is sent when it returns. A drag therefore never
// queues stale work, and the update rate follows the server's speed.
export interface LatestResult<I, O> {
  input: I;
  /** Sequence number of the input (increasing with every submit). */
  seq: number;
  output?: O;
  error?: unknown;
}

export class LatestWins<I, O> {
  private pending: { input: I; seq: number } | null = null;
  private busy = false;
  private seq = 0;
  private disposed = false;
  /** Requests actually sent (for tests and measurements). */
  sent = 0;

  constructor(
    private readonly run: (input: I) => Promise<O>,
    private readonly done: (r: LatestResult<I, O>) => void,
  ) {}

  /** Queues `input` as the newest; returns its sequence number. */
  submit(input: I): number {
    this.pending = { input, seq: ++this.seq };
    if (!this.busy) void this.pump();
    return this.seq;
  }

  get inFlight(): boolean {
    return this.busy;
  }

  private async pump(): Promise<void> {
    while (this.pending && !this.disposed) {
      const job = this.pending;
      this.pending = null;
      this.busy = true;
      this.sent++;
      let r: LatestResult<I, O>;
      try {
        r = { input: job.input, seq: job.seq, output: await this.run(job.input) };
      } catch (error) {
        r = { input: job.input, seq: job.seq, error };
      }
      this.busy = false;
      if (!this.disposed) this.done(r);
    }
  }

  dispose(): void {
    this.disposed = true;
    this.pending = null;
  }
}
