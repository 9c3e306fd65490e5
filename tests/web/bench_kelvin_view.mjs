// Issue 5's two front-end targets, measured in headless chromium (software WebGL, SwiftShader)
// against the real server: σ stroke → iso-surface frame drawn at a ~25k-vertex field, and frame
// times while orbiting a ~200k-triangle mesh. Prints JSON. Not a test (CTest runs *.test.mjs only).
// Usage: DISTLAB_EXE=build/backend/app/distlab [LX=0.05 STROKES=10 MOVES=240 SYNC=0 ORBIT=1 CACHE=dir BRUSH=narrow] node tests/web/bench_kelvin_view.mjs
// CACHE: a kept cache directory (the 200k-triangle sphere is prepared once, then loaded).
// SYNC=1: each frame waits for its pixels while σ latency is measured ("drawn" = rasterised, not
// merely submitted); that stalls the page's thread for the whole software render, so it slows
// everything else down: the default (0) reports submitted frames, and the orbit part reports what
// one frame costs SwiftShader (render_waited_ms, at full resolution; frames while dragging use the
// software renderer's interactive resolution). ORBIT=0 skips the 200k-triangle part, which orbits
// twice: with the surface's stand-in (STAND_IN=n triangles; the page's default when unset), then
// with the full surface.
// GPU_COMPOSITING=1 (harness.mjs): chromium without --disable-gpu composites in its GPU process as
// on a machine with a GPU; by default the software compositor reads every WebGL frame back on the
// page's main thread, which blocks it (and the WebSocket's messages) for the whole SwiftShader render.
// Stages of stroke → drawn (medians, ms): wait (event → σ sent: the previous edit's frames are on
// their way), ack (sent → server's acknowledgement), server (edit received → last frame sent, the
// server's own clock), frames (sent → last frame arrived), decode + accept (frames → geometries),
// raf_wait (geometries → the animation frame begins), render (that frame's render call).
// The strokes paint σ = 1 across the cube's top face, which shrinks the iso-surfaces (at l_x 0.05:
// 16.5k + 9.9k faces before, 5.9k + 5.7k after the 10 strokes): a SwiftShader frame then costs about a
// third, so the first strokes are the slowest and make the p95 (per_stroke_median_ms,
// shells_before/after show it). It is not a warm-up: with σ reset before each stroke, every stroke
// measured as slow as the first.
import { mkdtempSync, rmSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import path from "node:path";
import { launchBrowser, openView, startServer } from "./harness.mjs";

/** A closed UV sphere (radius 0.5 m: at the view's l_x 0.1 its mesh has interior vertices, which a
 *  0.1 m sphere has not, and the server refuses it) as binary STL with 2·n·(n−1) triangles. */
function uvSphereStl(n, r = 0.5) {
  // Closed: the seam (j = n is j = 0) and the poles are the same floats, so the importer welds them.
  const P = (i, j) => {
    if (i === 0 || i === n) return [0, 0, i === 0 ? r : -r];
    const th = (Math.PI * i) / n, ph = (2 * Math.PI * (j % n)) / n;
    return [r * Math.sin(th) * Math.cos(ph), r * Math.sin(th) * Math.sin(ph), r * Math.cos(th)];
  };
  const tris = [];
  for (let i = 0; i < n; i++)
    for (let j = 0; j < n; j++) {
      const a = P(i, j), b = P(i + 1, j), c = P(i + 1, j + 1), d = P(i, j + 1);
      if (i > 0) tris.push([a, b, d]);
      if (i < n - 1) tris.push([b, c, d]);
    }
  const buf = Buffer.alloc(84 + 50 * tris.length);
  buf.writeUInt32LE(tris.length, 80);
  tris.forEach((t, k) => t.forEach((p, v) => p.forEach((x, c) => buf.writeFloatLE(x, 84 + 50 * k + 12 + 12 * v + 4 * c))));
  return buf;
}
const work = mkdtempSync(path.join(tmpdir(), "distlab-bench-web-"));
const spherePath = path.join(work, "sphere200k.stl");
writeFileSync(spherePath, uvSphereStl(316)); // 199,080 triangles
const server = await startServer({ cacheDir: process.env.CACHE ?? path.join(work, "cache") });
const browser = await launchBrowser();
const med = (a) => { const s = [...a].sort((x, y) => x - y); return s.length ? s[Math.floor((s.length - 1) / 2)] : NaN; };
const pct = (a, p) => { const s = [...a].sort((x, y) => x - y); return s[Math.min(s.length - 1, Math.floor(p * s.length))]; };
const K = (page, e) => page.evaluate(`(() => { const k = window.distlab.kelvin; return ${e}; })()`);
const out = {};

/** Orbits with the real mouse (brush off): frame intervals, main-thread time per frame, long tasks,
 *  GL uploads meanwhile; then renders 30 frames back to back, each waited for (SwiftShader's time). */
async function orbit(p, moves) {
  await p.keyboard.press("b"); // brush off: every drag orbits
  await p.waitForTimeout(500);
  const box = await p.locator("canvas.viewport-canvas").boundingBox();
  await K(p, "k.resetFrameStats()");
  const up0 = await K(p, "k.glUploads ? k.glUploads() : null");
  await p.evaluate(() => {
    window.__long = [];
    new PerformanceObserver((l) => window.__long.push(...l.getEntries().map((x) => x.duration))).observe({ type: "longtask" });
  });
  const cx = box.x + box.width / 2, cy = box.y + box.height / 2;
  await p.mouse.move(cx, cy);
  await p.mouse.down();
  const t0 = Date.now();
  for (let i = 0; i < moves; i++) await p.mouse.move(cx + 200 * Math.sin(i / 20), cy + 60 * Math.cos(i / 30));
  await p.mouse.up();
  const secs = (Date.now() - t0) / 1000;
  const fs = await K(p, "k.frameStats()");
  const up1 = await K(p, "k.glUploads ? k.glUploads() : null");
  const longTasks = await p.evaluate(() => window.__long);
  await p.waitForTimeout(600); // past the interactive resolution's settle time: full-resolution frames
  const r = await K(p, "k.measureOrbit(30)");
  const driven = await K(p, "k.orbitDrive ? k.orbitDrive(120) : null");
  return {
    display_triangles: await K(p, "k.displayTriangles"), rendered_triangles: fs.triangles,
    stand_in: fs.standInFrames ? { ...(await K(p, "k.standIn")), frames: fs.standInFrames, frame_triangles: fs.standInFrameTriangles } : null, px: [r.width, r.height], mouse_moves: moves, frames: fs.frames, seconds: secs,
    frame_interval_ms: { median: fs.medianMs, p95: fs.p95Ms }, // rAF to rAF while dragging: bound by SwiftShader
    main_thread_per_frame_ms: fs.cpuMedianMs === undefined ? null : { median: fs.cpuMedianMs, p95: fs.cpuP95Ms }, // hooks + render() call, no GPU wait
    long_tasks: { count: longTasks.length, total_ms: longTasks.reduce((a, b) => a + b, 0), max_ms: Math.max(0, ...longTasks) },
    gl_uploads_during_orbit: up0 && up1 ? { bufferData: up1.bufferData - up0.bufferData, bufferSubData: up1.bufferSubData - up0.bufferSubData, textures: up1.texImage2D + up1.texSubImage2D - up0.texImage2D - up0.texSubImage2D, bytes: up1.bytes - up0.bytes, geometries: [up0.geometries, up1.geometries], draw_calls: up1.calls } : null,
    // The same drag driven from inside the page, one camera step per animation frame: what the
    // renderer sustains (≥ 16.7 ms: the display's frame), not the test's mouse events' pace.
    driven_frame_interval_ms: driven ? { median: driven.medianMs, p95: driven.p95Ms, frames: driven.frames, stand_in_frames: driven.standInFrames } : null,
    render_waited_ms: { median: med(r.times), p95: pct(r.times, 0.95) }, // one frame drawn by SwiftShader
    swiftshader_fps_bound: Math.round(1000 / med(r.times)),
    field_vertices: (await K(p, "k.object")).stats.n_verts,
  };
}
try {
  // A: σ latency. Cube, l_x = 0.05 (about 24k field vertices).
  const lx = Number(process.env.LX ?? 0.05);
  // The page's default brush (8% of the diagonal, 0.14 m): neighbouring strokes (0.078 m apart)
  // overlap. BRUSH=narrow paints with a brush narrower than their spacing, for A/B runs against
  // pages from before the brush painted towards its value (their overlapping stamps pushed σ past
  // the server's range, and the page stopped).
  const brush = process.env.BRUSH === "narrow" ? { brush: { on: true, value: 1, radius: 0.05, falloff: 0.02 } } : {};
  const page = await openView(browser, server, `#/kelvin?s=${encodeURIComponent(JSON.stringify({ object: "cube", lx, levels: [0, 0.25], ...brush }))}`);
  await page.waitForFunction(() => window.distlab?.kelvin?.ready === true, null, { timeout: 300000, polling: 200 });
  const nverts = (await K(page, "k.object")).stats.n_verts;
  const sync = process.env.SYNC === "1";
  const synced = await K(page, `k.syncRender ? (k.syncRender(${sync}), ${sync}) : false`);
  const strokes = Number(process.env.STROKES ?? 10);
  /** The shown iso-surfaces' faces and what a full-resolution frame of them costs (waited for). */
  const shells = async () => ({ faces: (await K(page, "k.shown")).map((f) => f.n_faces), render_waited_ms: med((await K(page, "k.measureOrbit(12)")).times) });
  const shellsBefore = await shells();
  const strokeStart = []; // σ version before each stroke
  for (let s = 0; s < strokes; s++) {
    const y = -0.35 + (0.7 * s) / Math.max(1, strokes - 1);
    const a = await K(page, `k.toScreen([-0.35, ${y}, 0.5])`), b = await K(page, `k.toScreen([0.35, ${y}, 0.5])`);
    const v = await K(page, "k.sigma.version");
    strokeStart.push(v);
    await page.mouse.move(a.x, a.y);
    await page.mouse.down();
    for (let i = 1; i <= 6; i++) await page.mouse.move(a.x + ((b.x - a.x) * i) / 6, a.y + ((b.y - a.y) * i) / 6);
    await page.mouse.up();
    await page.waitForFunction((v) => window.distlab.kelvin.sigma.version > v && window.distlab.kelvin.ready, v, { timeout: 60000 });
    await page.waitForTimeout(800);
  }
  const t = await K(page, "k.timings");
  const e = t.strokeToFrameMs;
  const strokeOf = (x) => strokeStart.findLastIndex((v) => x.version > v);
  const m = (f) => med(e.map(f));
  out.sigma = {
    lx, field_vertices: nverts, edits: e.length, brush: (await K(page, "k.state")).brush, stamps: (await K(page, "k.sigma")).body.brushes?.length ?? 0,
    stroke_to_frame_ms: { median: med(e.map((x) => x.ms)), p95: pct(e.map((x) => x.ms), 0.95) },
    sync_render: synced,
    breakdown_median_ms: e[0]?.serverMs === undefined
      ? { wait: m((x) => x.waitMs), put: m((x) => x.putMs), sent_to_frames: m((x) => x.framesMs), draw: m((x) => x.drawMs) }
      : { wait: m((x) => x.waitMs), ack: m((x) => x.putMs), server: m((x) => x.serverMs), sent_to_frames: m((x) => x.framesMs), decode: m((x) => x.decodeMs), accept: m((x) => x.acceptMs), raf_wait: m((x) => x.rafWaitMs), render: m((x) => x.renderMs), ready_to_drawn: m((x) => x.drawMs) },
    breakdown_p95_ms: { wait: pct(e.map((x) => x.waitMs), 0.95), ack: pct(e.map((x) => x.putMs), 0.95), server: pct(e.map((x) => x.serverMs), 0.95), sent_to_frames: pct(e.map((x) => x.framesMs), 0.95), raf_wait: pct(e.map((x) => x.rafWaitMs), 0.95) },
    sent_to_drawn_ms: m((x) => x.ms - x.waitMs),
    // Every edit: [whole, wait, ack, server, sent → frames, rAF wait] (ms), in order.
    per_edit: e.map((x) => [x.ms, x.waitMs, x.putMs, x.serverMs, x.framesMs, x.rafWaitMs].map((v) => Math.round(v))),
    per_stroke_median_ms: strokeStart.map((_, s) => Math.round(med(e.filter((x) => strokeOf(x) === s).map((x) => x.ms)))),
    shells_before: shellsBefore,
    shells_after: await shells(),
    stroke_to_colour_ms: { median: med(t.strokeToColourMs), p95: pct(t.strokeToColourMs, 0.95) },
    iso_faces: (await K(page, "k.shown")).map((f) => [f.level, f.n_faces]),
  };
  await K(page, "k.syncRender && k.syncRender(false)");
  out.orbit_cube = await orbit(page, Number(process.env.MOVES ?? 240) / 2);
  await page.close();
  console.error(JSON.stringify(out)); // the σ part, in case the 200k-triangle preparation times out
  // B: orbiting a ~200k-triangle uploaded surface (UV sphere, 199,080 triangles).
  if (process.env.ORBIT !== "0") await orbitLarge();
  console.log(JSON.stringify(out, null, 1));
} finally {
  await browser.close();
  await server.stop();
  rmSync(work, { recursive: true, force: true });
}

async function orbitLarge() {
  const standIn = process.env.STAND_IN; // the stand-in's triangles (the page's default when unset)
  const setup = (page) => standIn !== undefined && page.addInitScript((n) => localStorage.setItem("distlab.standInTriangles", n), standIn);
  const p2 = await openView(browser, server, `#/kelvin?s=${encodeURIComponent(JSON.stringify({ object: "sphere", lx: 0.1, levels: [0.3] }))}`, { setup });
  await p2.waitForFunction(() => window.distlab?.kelvin?.ready === true, null, { timeout: 120000 });
  await p2.setInputFiles("input[data-testid=kelvin-upload]", spherePath); // keeps the sphere's l_x 0.1
  // Ready, or the server's refusal shown as an error (reported instead of waiting for the timeout).
  await p2.waitForFunction(() => (window.distlab.kelvin.object?.source?.upload && window.distlab.kelvin.ready) || document.querySelector(".toast-error"), null, { timeout: 1800000, polling: 500 });
  const refused = await p2.locator(".toast-error").allTextContents();
  if (refused.length) throw new Error(`the 200k-triangle upload was not prepared: ${refused.join("; ")}`);
  // Side by side in one run: orbiting with the surface's stand-in (the default on a software
  // renderer), then with the full surface.
  await p2.waitForFunction(() => window.distlab.kelvin.standIn !== null, null, { timeout: 60000 }).catch(() => undefined);
  out.orbit = await orbit(p2, Number(process.env.MOVES ?? 240));
  await K(p2, "k.useStandIn(false)");
  await p2.keyboard.press("b"); // orbit() turns the brush off again
  out.orbit_full_surface = await orbit(p2, Number(process.env.MOVES ?? 240));
}
