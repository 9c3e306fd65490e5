// REST client for /api: one session per browser tab, errors as ApiError with the server's
// {"error": {code, message, field}} body. A server restart loses sessions: an unknown session
// (404 "session_not_found") makes a new one and retries once; `onNewSession` lets views rebuild.
import { decode } from "@msgpack/msgpack";

export class ApiError extends Error {
  constructor(
    readonly status: number,
    readonly code: string,
    message: string,
    readonly field?: string,
  ) {
    super(message);
  }
  /** "field: message" as shown to the user (the message alone if it starts with the field). */
  get readable(): string {
    return this.field && !this.message.startsWith(this.field) ? `${this.field}: ${this.message}` : this.message;
  }
}

/** Any thrown value as the user reads it (an API error as "field: message"). */
export function errorText(e: unknown): string {
  return e instanceof ApiError ? e.readable : e instanceof Error ? e.message : String(e);
}

type Json = unknown;
const SESSION_KEY = "distlab.session";

export class Api {
  // ?session=ID joins that session (a page of a Python client's session: its scene, its recordings).
  private session: string | null = new URLSearchParams(location.search).get("session") ?? sessionStorage.getItem(SESSION_KEY);
  private creating: Promise<string> | null = null;
  private newSessionListeners: Array<(id: string) => void> = [];

  constructor(readonly base = "") {}

  onNewSession(f: (id: string) => void): void {
    this.newSessionListeners.push(f);
  }

  async sessionId(): Promise<string> {
    if (this.session) return this.session;
    if (!this.creating) {
      this.creating = (async () => {
        const body = (await this.raw("POST", "/api/session", undefined, false)) as { id?: string; session?: string };
        const id = body.id ?? body.session;
        if (!id) throw new ApiError(500, "bad_response", "server did not return a session id");
        this.session = id;
        sessionStorage.setItem(SESSION_KEY, id);
        this.newSessionListeners.forEach((f) => f(id));
        return id;
      })().finally(() => (this.creating = null));
    }
    return this.creating;
  }

  get<T = Json>(path: string): Promise<T> {
    return this.call("GET", path) as Promise<T>;
  }
  post<T = Json>(path: string, body?: Json): Promise<T> {
    return this.call("POST", path, body) as Promise<T>;
  }
  put<T = Json>(path: string, body?: Json): Promise<T> {
    return this.call("PUT", path, body) as Promise<T>;
  }
  del<T = Json>(path: string): Promise<T> {
    return this.call("DELETE", path) as Promise<T>;
  }
  /** POST raw bytes (uploads). */
  upload<T = Json>(path: string, bytes: ArrayBuffer | Blob): Promise<T> {
    return this.call("POST", path, bytes) as Promise<T>;
  }
  /** GET a binary body: msgpack is decoded, anything else returned as a Blob. */
  async binary(path: string): Promise<{ blob: Blob; contentType: string; filename?: string; headers: Headers }> {
    const r = await this.fetchWithSession("GET", path);
    const blob = await r.blob();
    const cd = r.headers.get("content-disposition") ?? "";
    const m = /filename="?([^";]+)"?/.exec(cd);
    return { blob, contentType: r.headers.get("content-type") ?? "", filename: m?.[1], headers: r.headers };
  }
  async msgpack<T = Json>(method: string, path: string, body?: Json): Promise<T> {
    const r = await this.fetchWithSession(method, path, body);
    return decode(new Uint8Array(await r.arrayBuffer())) as T;
  }

  private async call(method: string, path: string, body?: Json | ArrayBuffer | Blob): Promise<Json> {
    const r = await this.fetchWithSession(method, path, body);
    const type = r.headers.get("content-type") ?? "";
    if (type.includes("msgpack")) return decode(new Uint8Array(await r.arrayBuffer()));
    const text = await r.text();
    return text ? JSON.parse(text) : null;
  }

  private async fetchWithSession(method: string, path: string, body?: Json | ArrayBuffer | Blob): Promise<Response> {
    const attempt = async () => {
      const id = await this.sessionId();
      return this.send(method, path, body, id);
    };
    let r = await attempt();
    if (r.status === 404 && (await isSessionError(r.clone()))) {
      this.session = null;
      sessionStorage.removeItem(SESSION_KEY);
      r = await attempt();
    }
    if (!r.ok) throw await toError(r);
    return r;
  }

  private async raw(method: string, path: string, body: Json, withSession: boolean): Promise<Json> {
    const r = await this.send(method, path, body, withSession ? await this.sessionId() : null);
    if (!r.ok) throw await toError(r);
    return r.json();
  }

  private send(method: string, path: string, body: Json | ArrayBuffer | Blob, session: string | null): Promise<Response> {
    const headers: Record<string, string> = {};
    if (session) headers["X-Distlab-Session"] = session;
    let payload: BodyInit | undefined;
    if (body instanceof ArrayBuffer || body instanceof Blob) {
      payload = body;
      headers["Content-Type"] = "application/octet-stream";
    } else if (body !== undefined) {
      payload = JSON.stringify(body);
      headers["Content-Type"] = "application/json";
    }
    return fetch(this.base + path, { method, headers, body: payload }).catch((e: unknown) => {
      throw new ApiError(0, "network", `cannot reach the server (${e instanceof Error ? e.message : String(e)})`);
    });
  }
}

async function isSessionError(r: Response): Promise<boolean> {
  try {
    const body = (await r.json()) as { error?: { code?: string; field?: string } };
    const e = body.error;
    return !!e && (e.code?.includes("session") === true || e.field === "session");
  } catch {
    return false;
  }
}

async function toError(r: Response): Promise<ApiError> {
  try {
    const body = (await r.json()) as { error?: { code?: string; message?: string; field?: string } };
    if (body.error) return new ApiError(r.status, body.error.code ?? "error", body.error.message ?? r.statusText, body.error.field ?? undefined);
  } catch {
    /* not JSON */
  }
  return new ApiError(r.status, "http_" + r.status, `${r.status} ${r.statusText}`);
}

export const api = new Api();
