// The /ws connection: JSON text messages by "type", binary msgpack frames (meshes). Reconnects
// with backoff after a server restart; before reconnecting it revalidates the session through the
// REST client (which makes a new one if the server forgot it), then asks for the current state.
// request() pairs a message with its reply by an id the server echoes (to this socket only), so
// an unrelated message of the same type (another tab's edit, a broadcast error) is never taken
// for the answer.
import { decode } from "@msgpack/msgpack";
import { api, Api } from "./api";
import type { WsClientMessage } from "./wire";

export type ConnectionState = "connecting" | "open" | "closed";
export type TextMessage = { type: string; [key: string]: unknown };
export type BinaryFrame = { type?: string; [key: string]: unknown };

type Listener<T> = (m: T) => void;

/** A request's reply did not come: not connected, timed out, or the connection closed first. */
export class SocketRequestError extends Error {}

interface Pending {
  resolve: (m: TextMessage) => void;
  reject: (e: Error) => void;
  timer: number;
}

export class Socket {
  private ws: WebSocket | null = null;
  private text = new Map<string, Set<Listener<TextMessage>>>();
  private binary = new Set<Listener<BinaryFrame>>();
  private stateListeners = new Set<Listener<ConnectionState>>();
  private openListeners = new Set<() => void>();
  private retry = 0;
  private timer: number | undefined;
  private requests = 0;
  private pending = new Map<string, Pending>();
  state: ConnectionState = "closed";
  /** performance.now() when the binary frame now being delivered arrived (before its decode). */
  frameArrivedAt = 0;

  constructor(private readonly client: Api = api) {}

  start(): void {
    void this.connect();
  }

  on(type: string, f: Listener<TextMessage>): () => void {
    if (!this.text.has(type)) this.text.set(type, new Set());
    this.text.get(type)!.add(f);
    return () => this.text.get(type)?.delete(f);
  }
  onFrame(f: Listener<BinaryFrame>): () => void {
    this.binary.add(f);
    return () => this.binary.delete(f);
  }
  onState(f: Listener<ConnectionState>): () => void {
    this.stateListeners.add(f);
    f(this.state);
    return () => this.stateListeners.delete(f);
  }
  /** Called on every (re)connection: views re-register what the server should push. */
  onOpen(f: () => void): () => void {
    this.openListeners.add(f);
    if (this.state === "open") f();
    return () => this.openListeners.delete(f);
  }

  send(message: WsClientMessage): boolean {
    if (!this.ws || this.ws.readyState !== WebSocket.OPEN) return false;
    this.ws.send(JSON.stringify(message));
    return true;
  }

  /** Sends the message with a fresh request id; resolves with the server's reply echoing it (an
   *  acknowledgement or an "error" message, both still delivered to on() listeners), or null
   *  when the socket is not open (the caller may use REST instead). */
  request(message: WsClientMessage, timeoutMs = 10000): Promise<TextMessage> | null {
    const id = `q${++this.requests}`;
    if (!this.send({ ...message, request: id })) return null;
    return new Promise<TextMessage>((resolve, reject) => {
      const timer = window.setTimeout(() => {
        this.pending.delete(id);
        reject(new SocketRequestError(`no answer to the ${message.type} request in ${timeoutMs / 1000} s`));
      }, timeoutMs);
      this.pending.set(id, { resolve, reject, timer });
    });
  }

  private settle(m: TextMessage): void {
    if (typeof m.request !== "string") return;
    const p = this.pending.get(m.request);
    if (!p) return;
    this.pending.delete(m.request);
    window.clearTimeout(p.timer);
    p.resolve(m);
  }

  private dropPending(): void {
    for (const p of this.pending.values()) {
      window.clearTimeout(p.timer);
      p.reject(new SocketRequestError("the connection closed before the server answered"));
    }
    this.pending.clear();
  }

  private setState(s: ConnectionState): void {
    this.state = s;
    this.stateListeners.forEach((f) => f(s));
  }

  private async connect(): Promise<void> {
    this.setState("connecting");
    let session: string;
    try {
      await this.client.get("/api/session"); // revalidates (or recreates) the session
      session = await this.client.sessionId();
    } catch {
      this.scheduleReconnect();
      return;
    }
    const url = new URL(`ws?session=${encodeURIComponent(session)}`, location.href);
    url.protocol = location.protocol === "https:" ? "wss:" : "ws:";
    const ws = new WebSocket(url);
    ws.binaryType = "arraybuffer";
    this.ws = ws;
    ws.onopen = () => {
      this.retry = 0;
      this.setState("open");
      this.openListeners.forEach((f) => f());
    };
    ws.onmessage = (ev: MessageEvent) => {
      if (typeof ev.data === "string") {
        let m: TextMessage;
        try {
          m = JSON.parse(ev.data) as TextMessage;
        } catch {
          return;
        }
        this.settle(m);
        this.text.get(m.type)?.forEach((f) => f(m));
        this.text.get("*")?.forEach((f) => f(m));
      } else {
        this.frameArrivedAt = performance.now();
        const frame = decode(new Uint8Array(ev.data as ArrayBuffer)) as BinaryFrame;
        this.binary.forEach((f) => f(frame));
      }
    };
    ws.onclose = () => {
      if (this.ws !== ws) return;
      this.ws = null;
      this.dropPending();
      this.scheduleReconnect();
    };
  }

  private scheduleReconnect(): void {
    this.setState("closed");
    clearTimeout(this.timer);
    const delay = Math.min(5000, 250 * 2 ** this.retry++);
    this.timer = window.setTimeout(() => void this.connect(), delay);
  }
}

export const socket = new Socket();
