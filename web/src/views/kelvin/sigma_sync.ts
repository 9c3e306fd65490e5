// σ to the server, one edit at a time: edits made meanwhile coalesce into the newest σ, sent once
// the previous σ's iso-surface frames are shown, so the server always works on the newest σ and
// the screen never lags behind a queue of stale edits.
import { api, ApiError } from "../../core/api";
import { socket, SocketRequestError } from "../../core/socket";
import { showError } from "../../core/toast";
import { Coalescer } from "./coalesce";
import type { EditTracer } from "./edit_trace";
import type { SigmaBody } from "./sigma";

export interface SigmaSyncHost {
  objectId(): string | null;
  body(): SigmaBody;
  /** The server applied σ as this version. */
  applied(version: number): void;
  /** Every watched level shows a frame of this σ version or a newer one. */
  shownAtLeast(version: number): boolean;
}

/** How long the next edit waits for the frames of the one before. */
const FRAMES_WAIT_MS = 3000;

export class SigmaSync {
  private coalescer = new Coalescer<void>(() => this.send());
  private waiters: Array<{ version: number; resolve: () => void }> = [];

  constructor(
    private readonly host: SigmaSyncHost,
    private readonly trace: EditTracer,
  ) {}

  /** σ changed: send it (now, or after the edit in flight). */
  push(): void {
    this.coalescer.push();
  }

  cancelPending(): void {
    this.coalescer.cancelPending();
  }

  /** New frames are shown: an edit waiting for them may go. */
  framesShown(): void {
    this.waiters = this.waiters.filter((w) => {
      if (!this.host.shownAtLeast(w.version)) return true;
      w.resolve();
      return false;
    });
  }

  private async send(): Promise<void> {
    const id = this.host.objectId();
    if (!id) return;
    this.trace.sent();
    try {
      const version = await putSigma(id, this.host.body());
      if (id !== this.host.objectId()) return this.trace.answered(null);
      this.trace.answered(version);
      this.host.applied(version);
      await this.framesFor(version);
    } catch (e) {
      this.trace.answered(null);
      showError(e, "σ not applied");
    }
  }

  private framesFor(version: number): Promise<void> {
    return new Promise((resolve) => {
      const w = { version, resolve };
      this.waiters.push(w);
      window.setTimeout(() => {
        this.waiters = this.waiters.filter((x) => x !== w);
        resolve();
      }, FRAMES_WAIT_MS);
      this.framesShown();
    });
  }
}

/** σ to the server: on the socket when open (no HTTP request per edit), else by PUT. The
 *  server answers a socket edit with a "sigma" message carrying its version, or an error, both
 *  echoing the edit's request id. A σ is a whole state, so an edit whose answer was lost with
 *  the connection is simply sent again by PUT. */
async function putSigma(id: string, body: SigmaBody): Promise<number> {
  const answer = socket.request({ type: "sigma", object: id, sigma: body });
  if (answer) {
    try {
      const m = await answer;
      if (m.type === "sigma" && m.object === id) return Number(m.sigma_version);
      const e = m.error as { code?: string; message?: string; field?: string } | undefined;
      throw new ApiError(Number(m.status ?? 500), e?.code ?? "error", e?.message ?? "σ not applied", e?.field);
    } catch (e) {
      if (!(e instanceof SocketRequestError)) throw e;
    }
  }
  return api.put<{ sigma_version: number }>(`/api/kelvin/objects/${id}/sigma`, body).then((r) => r.sigma_version);
}
