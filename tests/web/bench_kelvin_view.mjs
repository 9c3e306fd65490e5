// Issue 5's two front-end targets, measured in headless chromium (software WebGL, SwiftShader)
// against the real server: σ stroke → iso-surface frame drawn at a ~25k-vertex field, and frame
// times while orbiting a ~200k-triangle mesh. Prints JSON. Not a test (CTest runs *.test.mjs only).
// Usage: DISTLAB_EXE=build/backend/app/distlab [LX=0.05 STROKES=10 MOVES=240] node tests/web/bench_kelvin_view.mjs
import { mkdtempSync, writeFileSync } from "node:fs";
import { tmpdir } from "node:os";
import path from "node:path";
import { launchBrowser, openView, startServer } from "./harness.mjs";

/** A closed UV sphere (radius 0.1 m) as binary STL with 2·n·(n−1) triangles. */
function uvSphereStl(n) {
  const P = (i, j) => {
    const th = (Math.PI * i) / n, ph = (2 * Math.PI * j) / n;
    return [0.1 * Math.sin(th) * Math.cos(ph), 0.1 * Math.sin(th) * Math.sin(ph), 0.1 * Math.cos(th)];
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
const server = await startServer({ cacheDir: path.join(work, "cache") });
const browser = await launchBrowser();
const med = (a) => { const s = [...a].sort((x, y) => x - y); return s.length ? s[Math.floor((s.length - 1) / 2)] : NaN; };
const pct = (a, p) => { const s = [...a].sort((x, y) => x - y); return s[Math.min(s.length - 1, Math.floor(p * s.length))]; };
const K = (page, e) => page.evaluate(`(() => { const k = window.distlab.kelvin; return ${e}; })()`);
const out = {};
try {
  // A: σ latency. Cube, l_x = 0.05 (about 24k field vertices).
  const lx = Number(process.env.LX ?? 0.05);
  const page = await openView(browser, server, `#/kelvin?s=${encodeURIComponent(JSON.stringify({ object: "cube", lx, levels: [0, 0.25] }))}`);
  await page.waitForFunction(() => window.distlab?.kelvin?.ready === true, null, { timeout: 300000, polling: 200 });
  const nverts = (await K(page, "k.object")).stats.n_verts;
  const strokes = Number(process.env.STROKES ?? 10);
  for (let s = 0; s < strokes; s++) {
    const y = -0.35 + (0.7 * s) / Math.max(1, strokes - 1);
    const a = await K(page, `k.toScreen([-0.35, ${y}, 0.5])`), b = await K(page, `k.toScreen([0.35, ${y}, 0.5])`);
    const v = await K(page, "k.sigma.version");
    await page.mouse.move(a.x, a.y);
    await page.mouse.down();
    for (let i = 1; i <= 6; i++) await page.mouse.move(a.x + ((b.x - a.x) * i) / 6, a.y + ((b.y - a.y) * i) / 6);
    await page.mouse.up();
    await page.waitForFunction((v) => window.distlab.kelvin.sigma.version > v && window.distlab.kelvin.ready, v, { timeout: 60000 });
    await page.waitForTimeout(800);
  }
  const t = await K(page, "k.timings");
  const e = t.strokeToFrameMs;
  out.sigma = {
    lx, field_vertices: nverts, edits: e.length,
    stroke_to_frame_ms: { median: med(e.map((x) => x.ms)), p95: pct(e.map((x) => x.ms), 0.95) },
    breakdown_median_ms: { wait: med(e.map((x) => x.waitMs)), put: med(e.map((x) => x.putMs)), sent_to_frames: med(e.map((x) => x.framesMs)), draw: med(e.map((x) => x.drawMs)) },
    stroke_to_colour_ms: { median: med(t.strokeToColourMs), p95: pct(t.strokeToColourMs, 0.95) },
    iso_faces: (await K(page, "k.shown")).map((f) => [f.level, f.n_faces]),
  };
  const small = await K(page, "k.measureOrbit(30)");
  out.orbit_cube = { triangles: small.triangles, px: [small.width, small.height], render_ms: { median: med(small.times), p95: pct(small.times, 0.95) } };
  await page.close();

  // B: orbiting a ~200k-triangle uploaded surface (UV sphere, 199,200 triangles).
  const p2 = await openView(browser, server, `#/kelvin?s=${encodeURIComponent(JSON.stringify({ object: "sphere", lx: 0.1, levels: [0.3] }))}`);
  await p2.waitForFunction(() => window.distlab?.kelvin?.ready === true, null, { timeout: 120000 });
  await p2.setInputFiles("input[data-testid=kelvin-upload]", spherePath); // keeps the sphere's l_x 0.1
  await p2.waitForFunction(() => window.distlab.kelvin.object?.source?.upload && window.distlab.kelvin.ready, null, { timeout: 600000, polling: 500 });
  await p2.keyboard.press("b"); // brush off: every drag orbits
  await p2.waitForTimeout(500);
  const box = await p2.locator("canvas.viewport-canvas").boundingBox();
  await K(p2, "k.resetFrameStats()");
  const cx = box.x + box.width / 2, cy = box.y + box.height / 2;
  await p2.mouse.move(cx, cy);
  await p2.mouse.down();
  const t0 = Date.now();
  for (let i = 0; i < Number(process.env.MOVES ?? 240); i++) await p2.mouse.move(cx + 200 * Math.sin(i / 20), cy + 60 * Math.cos(i / 30));
  await p2.mouse.up();
  const secs = (Date.now() - t0) / 1000;
  const fs = await K(p2, "k.frameStats()");
  const big = await K(p2, "k.measureOrbit(30)");
  out.orbit_render = { triangles: big.triangles, px: [big.width, big.height], render_ms: { median: med(big.times), p95: pct(big.times, 0.95) } };
  out.orbit = { display_triangles: await K(p2, "k.displayTriangles"), rendered_triangles: fs.triangles, frames: fs.frames, seconds: secs, frame_interval_ms: { median: fs.medianMs, p95: fs.p95Ms }, field_vertices: (await K(p2, "k.object")).stats.n_verts };
  console.log(JSON.stringify(out, null, 1));
} finally {
  await browser.close();
  await server.stop();
}
