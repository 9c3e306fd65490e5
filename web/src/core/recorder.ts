// The page side of Client.record: a page opened with ?session=ID&record=RECORDING (by headless
// chromium, which Client.record starts) reads the recording's request, waits until its view and
// the session's scene items are drawn, records the view's canvas (WebM through MediaRecorder, or
// one PNG per frame) and uploads it part by part; the server keeps it for the client to fetch.
// A recording forgotten on the server (cancelled) answers 404 to the next part: the page stops.
import { api, errorText } from "./api";
import { socket } from "./socket";
import { userSceneItems } from "./user_scene";
import { currentViewport } from "./user_scene_draw";
import type { Viewport } from "./viewport";

interface Recording {
  id: string;
  view: string;
  format: "webm" | "png";
  fps: number;
  frames: number;
  seconds: number;
}

const nextFrame = () => new Promise<number>((resolve) => requestAnimationFrame(resolve));
const sleep = (ms: number) => new Promise((resolve) => window.setTimeout(resolve, ms));

/** Resolves once `ready()` holds, checked every animation frame; rejects after `ms`. */
async function until(ready: () => boolean, what: string, ms = 20000): Promise<void> {
  const end = performance.now() + ms;
  while (!ready()) {
    if (performance.now() > end) throw new Error(`the page did not get ready to record: ${what}`);
    await nextFrame();
  }
}

/** What a recording holds: its frames and the time they span (the last one shown for 1 / fps). */
interface Recorded {
  frames: number;
  seconds: number;
}

/** The recording's frames, each drawn anew and handed to `take` at its time (frame i at i / fps
 *  from the first; later when the renderer is slower: software WebGL on a loaded machine). */
async function drawFrames(vp: Viewport, r: Recording, take: (i: number) => Promise<void> | void): Promise<Recorded> {
  let first = 0,
    last = 0;
  for (let i = 0; i < r.frames; i++) {
    if (i > 0) await sleep(first + (i * 1000) / r.fps - performance.now());
    vp.invalidate();
    await nextFrame(); // the view draws in this animation frame
    await nextFrame();
    last = performance.now(); // when the frame is taken: what a WebM block's time is
    if (i === 0) first = last;
    await take(i);
  }
  return { frames: r.frames, seconds: (last - first) / 1000 + 1 / r.fps };
}

/** A WebM of exactly the recording's frames: the canvas stream takes a frame only when asked
 *  (captureStream(0) + requestFrame), so a slow renderer makes a longer video, never fewer frames. */
async function recordWebm(vp: Viewport, r: Recording): Promise<{ blob: Blob; recorded: Recorded }> {
  const type = ["video/webm;codecs=vp9", "video/webm;codecs=vp8", "video/webm"].find((t) => MediaRecorder.isTypeSupported(t));
  if (!type) throw new Error("this browser's MediaRecorder writes no WebM");
  const stream = vp.renderer.domElement.captureStream(0);
  const track = stream.getVideoTracks()[0] as MediaStreamTrack & { requestFrame(): void };
  const recorder = new MediaRecorder(stream, { mimeType: type });
  const chunks: Blob[] = [];
  recorder.ondataavailable = (e) => e.data.size && chunks.push(e.data);
  const stopped = new Promise((resolve) => (recorder.onstop = resolve));
  recorder.start();
  const recorded = await drawFrames(vp, r, () => track.requestFrame());
  await sleep(1000 / r.fps); // the last frame's time on screen
  recorder.stop();
  await stopped;
  const blob = new Blob(chunks, { type: "video/webm" });
  // The encoder stamps a frame when it takes it, later than requestFrame on a loaded machine: the
  // file's own block times say what it holds, the page's clock does not.
  const times = webmFrameTimes(new Uint8Array(await blob.arrayBuffer()));
  if (times.length !== recorded.frames) throw new Error(`the WebM holds ${times.length} frames, not the ${recorded.frames} drawn`);
  return { blob, recorded: { frames: times.length, seconds: (Math.max(...times) - Math.min(...times)) / 1000 + 1 / r.fps } };
}

/** Each frame's time in ms in a WebM (Matroska) file: its Cluster's timecode plus its SimpleBlock's
 *  or Block's own, times the Segment's TimecodeScale. A flat walk over the EBML elements: it enters
 *  the Segment, its Info, Clusters (whose sizes a live recorder leaves unknown) and BlockGroups. */
export function webmFrameTimes(data: Uint8Array): number[] {
  const vint = (i: number, keepMarker: boolean): [number, number, boolean] => {
    const n = Math.clz32(data[i] ?? 0) - 23; // 1 for 0b1xxxxxxx, … 8 for 0b00000001
    if (n < 1 || n > 8 || i + n > data.length) throw new Error(`the WebM is malformed at byte ${i}`);
    let v = keepMarker ? data[i] : data[i] & (0xff >> n);
    let ones = v === 0xff >> n;
    for (let k = 1; k < n; k++) {
      v = v * 256 + data[i + k];
      ones &&= data[i + k] === 0xff;
    }
    return [v, i + n, ones && !keepMarker];
  };
  const entered = new Set([0x18538067, 0x1549a966, 0x1f43b675, 0xa0]); // Segment, Info, Cluster, BlockGroup
  const uint = (a: number, b: number) => data.subarray(a, b).reduce((v, x) => v * 256 + x, 0);
  let i = 0,
    scale = 1e6,
    cluster = 0;
  const ticks: number[] = [];
  while (i < data.length) {
    const [id, j] = vint(i, true);
    const [size, body, unknown] = vint(j, false);
    if (entered.has(id)) {
      i = body;
      continue;
    }
    if (unknown || body + size > data.length) throw new Error(`the WebM's element ${id.toString(16)} at byte ${i} has no size`);
    if (id === 0x2ad7b1) scale = uint(body, body + size);
    else if (id === 0xe7) cluster = uint(body, body + size);
    else if (id === 0xa3 || id === 0xa1) {
      const [, k] = vint(body, false); // the track number
      if (k + 2 > body + size) throw new Error(`the WebM's block at byte ${i} has no timecode`);
      ticks.push(cluster + ((((data[k] << 8) | data[k + 1]) << 16) >> 16));
    }
    i = body + size;
  }
  return ticks.map((t) => (t * scale) / 1e6);
}

async function record(id: string): Promise<void> {
  const path = `/api/scene/recordings/${encodeURIComponent(id)}`;
  const r = await api.get<Recording>(path);
  // The view's viewport, the socket, and every item the session holds now, drawn.
  const held = ((await api.get<{ items: unknown[] }>("/api/scene/items")).items ?? []).length;
  await until(() => currentViewport() !== null && socket.state === "open", "no open view");
  await until(() => userSceneItems().length >= held, "the scene items did not arrive");
  await nextFrame();
  await nextFrame();
  const vp = currentViewport()!;
  let recorded: Recorded;
  if (r.format === "png") {
    recorded = await drawFrames(vp, r, async (i) => void (await api.put(`${path}/parts/${i}`, await vp.screenshot())));
  } else {
    const webm = await recordWebm(vp, r);
    recorded = webm.recorded;
    await api.put(`${path}/parts/0`, webm.blob);
  }
  const canvas = vp.renderer.domElement;
  const clip = vp.camera.projectionMatrix.clone().multiply(vp.camera.matrixWorldInverse);
  await api.post(`${path}/finish`, { camera: { matrix: clip.elements, width: canvas.width, height: canvas.height }, recorded: { ...recorded } });
}

// A recording page shows the view's canvas alone, filling the window (no bars, panel or plots).
const RECORDING_CSS = `#topbar, #progress, #panel, #bottom, #toasts { display: none !important; }
#app { position: fixed !important; inset: 0 !important; display: block !important; }
#canvas { width: 100% !important; height: 100% !important; }`;

/** Records the view when the page's URL asks for it (?record=ID); otherwise does nothing. */
export async function recordIfAsked(): Promise<void> {
  const id = new URLSearchParams(location.search).get("record");
  if (!id) return;
  const style = document.createElement("style");
  style.textContent = RECORDING_CSS;
  document.head.appendChild(style);
  try {
    await record(id);
  } catch (e) {
    await api.post(`/api/scene/recordings/${encodeURIComponent(id)}/finish`, { error: errorText(e) }).catch(() => undefined);
  }
}
