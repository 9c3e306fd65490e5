// One request in flight at a time; while it runs, newer inputs replace each other and only the
// latest is sent next (an edit made during a drag is never queued behind stale ones).
export class Coalescer<T> {
  private latest: { value: T } | null = null;
  private running = false;
  private idle: Array<() => void> = [];

  constructor(private readonly send: (value: T) => Promise<void>) {}

  push(value: T): void {
    this.latest = { value };
    if (!this.running) void this.drain();
  }

  /** Resolves once nothing is pending or in flight. */
  settled(): Promise<void> {
    if (!this.running && !this.latest) return Promise.resolve();
    return new Promise((r) => this.idle.push(r));
  }

  cancelPending(): void {
    this.latest = null;
  }

  private async drain(): Promise<void> {
    this.running = true;
    while (this.latest) {
      const { value } = this.latest;
      this.latest = null;
      try {
        await this.send(value);
      } catch {
        /* the sender reports its own errors */
      }
    }
    this.running = false;
    this.idle.splice(0).forEach((f) => f());
  }
}
