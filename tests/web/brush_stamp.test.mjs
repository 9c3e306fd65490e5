// The brush's stamp rule (web/src/views/kelvin/brush_stamp.ts) on a flat 2 m × 2 m grid of surface
// points, without a browser: strokes at the page's default spacing (half the radius, falloff half
// the radius) that overlap, and random strokes of any spacing, overlap and target. Painting towards
// v moves σ at every point monotonically towards v and never past it (σ stays between σ before the
// stamp and v), and a stroke leaves no gap: σ = v within its radius's band around the path.
// The TypeScript module is transpiled with the project's own TypeScript (web/node_modules).
import test from "node:test";
import assert from "node:assert/strict";
import { mkdtempSync, readFileSync, rmSync, writeFileSync } from "node:fs";
import { createRequire } from "node:module";
import { tmpdir } from "node:os";
import path from "node:path";
import { pathToFileURL } from "node:url";

const source = process.env.DISTLAB_SOURCE_DIR ?? path.resolve(import.meta.dirname, "../..");
const ts = createRequire(path.join(source, "web", "package.json"))("typescript");
const ts_src = readFileSync(path.join(source, "web/src/views/kelvin/brush_stamp.ts"), "utf8");
const js = ts.transpileModule(ts_src, { compilerOptions: { module: ts.ModuleKind.ESNext, target: ts.ScriptTarget.ES2022 } }).outputText;
const dir = mkdtempSync(path.join(tmpdir(), "distlab-brush-"));
const file = path.join(dir, "brush_stamp.mjs");
writeFileSync(file, js);
const { applyBrush, brushWeight, stampTowards } = await import(pathToFileURL(file).href);
rmSync(dir, { recursive: true }); // the module is loaded; nothing of the test stays behind

const H = 0.0125; // grid step: 161 × 161 points on z = 0
const N = 161;
function grid(sigma0) {
  const positions = new Float64Array(3 * N * N);
  for (let j = 0; j < N; j++)
    for (let i = 0; i < N; i++) positions.set([-1 + H * i, -1 + H * j, 0], 3 * (j * N + i));
  return { positions, sigma: new Float64Array(N * N).fill(sigma0) };
}

/** One stamp applied to every grid point it reaches; checks that each point moves towards the
 *  stamp's value and not past it. Returns the largest |σ| seen. */
function applyChecked(g, b, v) {
  let maxAbs = 0;
  const reach = b.radius + b.falloff;
  for (let k = 0; k < g.sigma.length; k++) {
    if (Math.abs(g.positions[3 * k] - b.center[0]) > reach || Math.abs(g.positions[3 * k + 1] - b.center[1]) > reach) continue;
    const before = g.sigma[k];
    const after = applyBrush(b, before, g.positions, 3 * k);
    const lo = Math.min(v, before), hi = Math.max(v, before);
    if (!(after >= lo - 1e-12 && after <= hi + 1e-12))
      assert.fail(`σ at (${g.positions[3 * k].toFixed(4)}, ${g.positions[3 * k + 1].toFixed(4)}) went from ${before} to ${after}, outside [${lo}, ${hi}] (painting towards ${v})`);
    g.sigma[k] = after;
    maxAbs = Math.max(maxAbs, Math.abs(after));
  }
  return maxAbs;
}

/** A stroke along the polyline `path` as BrushTool.paintAt places it: the pointer moves in steps of
 *  `step`, a stamp is considered where it has moved `spacing` from the last one considered.
 *  Returns the number of stamps and the centres considered (the stroke's path as painted). */
function stroke(g, settings, pathPts, spacing, step = H / 4) {
  let last = null, stamps = 0;
  const centres = [];
  for (let s = 0; s + 1 < pathPts.length; s++) {
    const [a, b] = [pathPts[s], pathPts[s + 1]];
    const len = Math.hypot(b[0] - a[0], b[1] - a[1]);
    for (let t = 0; t <= len + 1e-12; t += step) {
      const p = [a[0] + ((b[0] - a[0]) * t) / len, a[1] + ((b[1] - a[1]) * t) / len, 0];
      if (last && Math.hypot(p[0] - last[0], p[1] - last[1]) < spacing) continue;
      last = p;
      centres.push(p);
      const stamp = stampTowards(settings, p, g.positions, g.sigma);
      if (!stamp) continue;
      stamps++;
      const maxAbs = applyChecked(g, stamp, settings.value);
      assert.ok(maxAbs <= 300, `|σ| = ${maxAbs} passed the server's limit 300`);
    }
  }
  return { stamps, centres };
}

/** Distance from (x, y) to the polyline. */
function distanceTo(pathPts, x, y) {
  let d = Infinity;
  for (let s = 0; s + 1 < pathPts.length; s++) {
    const [a, b] = [pathPts[s], pathPts[s + 1]];
    const ex = b[0] - a[0], ey = b[1] - a[1];
    const t = Math.max(0, Math.min(1, ((x - a[0]) * ex + (y - a[1]) * ey) / (ex * ex + ey * ey)));
    d = Math.min(d, Math.hypot(x - a[0] - t * ex, y - a[1] - t * ey));
  }
  return d;
}

/** Every grid point within `band` of the path through the stamps' centres has σ = v (to the skip
 *  tolerance, 1e-3 of v). */
function assertCovered(g, pathPts, band, v) {
  const tol = 1e-3 * Math.max(1, Math.abs(v));
  const xs = pathPts.map((p) => p[0]), ys = pathPts.map((p) => p[1]);
  const [x0, x1, y0, y1] = [Math.min(...xs) - band, Math.max(...xs) + band, Math.min(...ys) - band, Math.max(...ys) + band];
  for (let k = 0; k < g.sigma.length; k++) {
    const x = g.positions[3 * k], y = g.positions[3 * k + 1];
    if (x < x0 || x > x1 || y < y0 || y > y1) continue;
    if (distanceTo(pathPts, x, y) > band) continue;
    if (Math.abs(g.sigma[k] - v) > tol) assert.fail(`gap: σ(${x.toFixed(4)}, ${y.toFixed(4)}) = ${g.sigma[k]}, ${distanceTo(pathPts, x, y).toFixed(4)} m from the stroke painted towards ${v}`);
  }
}

test("a stamp's weight is 1 within its radius and the smoothstep over its falloff; towards v it moves σ by that weight, added it adds value · weight", () => {
  const b = { center: [0, 0, 0], radius: 0.25, value: 1.5, falloff: 0.5, mode: "towards" };
  assert.equal(brushWeight(b, [0.1, 0, 0]), 1);
  assert.equal(brushWeight(b, [0, 0.5, 0]), 0.5); // halfway through the falloff: 3/4 − 2/8
  assert.equal(brushWeight(b, [0, 0, 0.75]), 0);
  assert.equal(applyBrush(b, -0.5, [0.1, 0, 0]), 1.5);
  assert.equal(applyBrush(b, -0.5, [0, 0.5, 0]), 0.5);
  assert.equal(applyBrush(b, -0.5, [0, 0, 0.8]), -0.5);
  // A brush without mode is the added term of links and files written before "towards".
  const added = { center: [0, 0, 0], radius: 0.25, value: 1.5, falloff: 0.5 };
  assert.equal(applyBrush(added, -0.5, [0, 0.5, 0]), 0.25);
});

test("overlapping strokes at the default brush (spacing r/2, falloff r/2) converge to the value without passing it, and cover their band", () => {
  const r = 0.1, settings = { value: 1, radius: r, falloff: r / 2 };
  const g = grid(-0.5);
  // 20 horizontal strokes 0.375 r apart, then 20 vertical ones over them, then the same again
  // towards −2 and back towards 1: every stamp overlaps the ones before it.
  const strokes = [];
  for (let j = 0; j < 20; j++) strokes.push([[-0.6, -0.36 + 0.0375 * j], [0.6, -0.36 + 0.0375 * j]]);
  for (let j = 0; j < 20; j++) strokes.push([[-0.36 + 0.0375 * j, -0.6], [-0.36 + 0.0375 * j, 0.6]]);
  for (const value of [1, -2, 1]) {
    for (const p of strokes) {
      assertCovered(g, stroke(g, { ...settings, value }, p, r / 2).centres, 0.9 * r, value);
    }
  }
  // Where σ is the value already a stroke changes nothing and adds no stamps.
  assert.equal(stroke(grid(1), settings, strokes[3], r / 2).stamps, 0);
  assert.ok(stroke(grid(1 - 0.01), settings, strokes[3], r / 2).stamps > 0);
});

test("strokes of any spacing, overlap, radius, falloff and target keep σ between its value before and the target, and leave no gap", () => {
  let seed = 12345;
  const rand = () => ((seed = (seed * 1103515245 + 12345) % 2147483648) / 2147483648);
  const g = grid(0.3);
  for (let n = 0; n < 60; n++) {
    const r = 0.03 + 0.15 * rand();
    const settings = { value: -3 + 6 * rand(), radius: r, falloff: r * 1.5 * rand() };
    const spacing = r * [0.1, 0.25, 0.5, 1, 1.5][Math.floor(5 * rand())];
    const pts = [0, 1, 2].map(() => [-0.7 + 1.4 * rand(), -0.7 + 1.4 * rand()]);
    const { centres } = stroke(g, settings, pts, spacing);
    // Discs of radius r at most `spacing` apart cover the band of √(r² − (spacing/2)²) about the
    // path through their centres.
    if (spacing <= r) assertCovered(g, centres, 0.99 * Math.sqrt(r * r - (spacing / 2) ** 2), settings.value);
  }
});
