// The surface of the object being prepared: the server pushes it on the socket once per object,
// possibly before the page knows the object's id; REST is the fallback, so a ~4 MB surface is
// fetched twice only when the socket's frame cannot come.
import { api, ApiError } from "../../core/api";
import { isMeshFrame, type MeshFrame } from "../../core/meshframe";
import { socket } from "../../core/socket";

/** How long a ready object's surface is awaited on the socket before it is fetched by REST. The
 *  server sends it right after the "ready" message (before any iso-surface); this only covers a
 *  frame that cannot come (the socket closed meanwhile) without fetching ~4 MB twice when it is
 *  merely queued behind other work on the server. */
const SURFACE_SOCKET_WAIT_MS = 10000;

/** Where a shown surface came from: the socket's frame, or REST when that did not come. */
export type SurfaceOrigin = "socket" | "rest";

export class SurfaceSource {
  origin: SurfaceOrigin | null = null;
  // The surface frame pushed on the socket for the object being prepared, until of() takes it.
  private pushed: MeshFrame | null = null;
  private waiter: { id: string; take: (f: MeshFrame) => void; cancel: () => void } | null = null;
  // Frames of an object whose id the page does not know yet (see keepUnclaimed).
  private unclaimed: MeshFrame[] = [];

  /** Another object is chosen: the surface awaited for the last one is not wanted. */
  reset(): void {
    this.pushed = null;
    this.waiter?.cancel();
    this.origin = null;
  }

  /** The socket pushed the surface of the object being prepared. */
  surfacePushed(f: MeshFrame): void {
    const waiter = this.waiter;
    if (waiter && waiter.id === f.object) waiter.take(f);
    else this.pushed = f;
  }

  /** A prepared object shared from the server's memory is ready (and its frames pushed) before
   *  our POST has returned its id: a few such frames are kept until claim(). */
  keepUnclaimed(f: MeshFrame): void {
    this.unclaimed.push(f);
    if (this.unclaimed.length > 32) this.unclaimed.shift();
  }

  /** The frames kept for the object `id`, now that it is ours. */
  claim(id: string): MeshFrame[] {
    const mine = this.unclaimed.filter((f) => f.object === id);
    this.unclaimed = this.unclaimed.filter((f) => f.object !== id);
    return mine;
  }

  /** The ready object's surface: the frame the server pushes on the socket once per object (it
   *  may have come already); by REST only when the socket is closed or the frame does not come. */
  of(id: string): Promise<MeshFrame> {
    const pushed = this.pushed;
    this.pushed = null;
    if (pushed?.object === id) {
      this.origin = "socket";
      return Promise.resolve(pushed);
    }
    return new Promise<MeshFrame>((resolve, reject) => {
      let settled = false;
      const settle = (f: MeshFrame | null, e?: unknown) => {
        if (settled) return;
        settled = true;
        window.clearTimeout(timer);
        if (this.waiter === waiter) this.waiter = null;
        if (f) resolve(f);
        else reject(e);
      };
      const waiter = {
        id,
        take: (f: MeshFrame) => {
          if (!settled) this.origin = "socket";
          settle(f);
        },
        cancel: () => settle(null, new ApiError(0, "cancelled", "another object was chosen")),
      };
      const fromRest = () => {
        if (settled) return;
        api.get<MeshFrame>(`/api/kelvin/objects/${id}/surface`).then(
          (f) => {
            if (!isMeshFrame(f)) return settle(null, new Error("the server's surface is not a mesh frame"));
            if (!settled) this.origin = "rest";
            settle(f);
          },
          (e) => settle(null, e),
        );
      };
      this.waiter = waiter;
      const timer = window.setTimeout(fromRest, socket.state === "open" ? SURFACE_SOCKET_WAIT_MS : 0);
    });
  }
}
