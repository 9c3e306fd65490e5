// The GAP explorer against the real server: it loads, a real mouse drag on the gizmo changes D,
// the readout equals a direct POST /api/gap/distance for the state in the URL, refused
// parameters show the server's message, the sweep plot holds GAP and Euclidean series (and its
// derivative is the derivative of D), a shared URL restores the same D; an error toast goes once
// its value is valid again, a refused sweep marks its plots stale. Measurements (drag →
// readout latency, frame intervals while orbiting) are printed, never asserted.
import { test } from "node:test";
import assert from "node:assert/strict";
import { direct as directRequest, hook, settled, urlState } from "./gap_page.mjs";
import { canvasPixels, differentBytes, openView, screenshot, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();

const median = (a) => [...a].sort((x, y) => x - y)[Math.floor(a.length / 2)];
const direct = (state) => directRequest(env.server, state);

async function readoutNumbers(page) {
  const text = async (f) => (await page.locator(`.gap-readout [data-field=${f}]`).textContent()) ?? "";
  const num = (t) => /=\s*([-0-9.e]+)/.exec(t)?.[1];
  return { D: num(await text("gap-d")), lambda: num(await text("gap-lambda")), euclid: num(await text("euclid-d")), iter: await text("gap-iter") };
}

/** Hovers along the projected +axis from the dragged shape's origin until the gizmo takes that axis. */
async function grabGizmo(page, axis = "X") {
  const sel = await hook(page, "selected()");
  const st = await hook(page, "state()");
  const o = st[sel].position;
  const tip = [o[0] + (axis === "X" ? 1 : 0), o[1] + (axis === "Y" ? 1 : 0), o[2] + (axis === "Z" ? 1 : 0)];
  const p0 = await page.evaluate((p) => window.distlab.gap.toScreen(p), o);
  const p1 = await page.evaluate((p) => window.distlab.gap.toScreen(p), tip);
  const len = Math.hypot(p1.x - p0.x, p1.y - p0.y);
  const dir = { x: (p1.x - p0.x) / len, y: (p1.y - p0.y) / len };
  for (let d = 12; d < 160; d += 4) {
    const at = { x: p0.x + dir.x * d, y: p0.y + dir.y * d };
    await page.mouse.move(at.x, at.y);
    if ((await hook(page, "gizmoAxis()")) === axis) return { at, dir };
  }
  throw new Error(`no gizmo ${axis} handle found along the projected axis`);
}

test("the explorer loads: live GAP and Euclidean numbers, verdict, level sets, sweep", async () => {
  const page = await openView(env.browser, env.server, "#/gap");
  await settled(page);
  const r = await hook(page, "result()");
  assert.ok(r.distance > 0 && r.euclidean.distance > r.distance, "default pair is separated; GAP D is below the Euclidean distance here");
  const shown = await readoutNumbers(page);
  assert.equal(shown.D, r.distance.toPrecision(6));
  assert.equal(shown.euclid, r.euclidean.distance.toPrecision(6));
  assert.match(await page.locator("#status").textContent(), /GAP D = .* Euclidean d = /);
  const verdict = page.locator("[data-testid=gap-verdict]");
  assert.match(await verdict.textContent(), /Property 2 holds/);
  assert.ok(await verdict.evaluate((e) => e.classList.contains("ok")), "verdict is green");

  await page.waitForFunction(() => window.distlab.gap.iso().surfaces.length > 0, null, { timeout: 60000 });
  const iso = await hook(page, "iso()");
  assert.deepEqual(iso.surfaces.map((s) => s.level).sort(), [0.002, 0.008], "both E_S levels as nested surfaces");
  assert.ok(iso.surfaces.every((s) => s.field === "strict" && s.triangles > 100));
  assert.equal(iso.slice, "strict");
  assert.ok(iso.sliceRange[1] > 0, "slice coloured by a non-constant field");

  await page.waitForFunction(() => window.distlab.gap.sweep().data !== null, null, { timeout: 30000 });
  const sw = await hook(page, "sweep()");
  assert.deepEqual(sw.plots[0].labels, ["GAP D", "Euclidean d"]);
  assert.deepEqual(sw.plots[1].labels, ["GAP dD/ds", "Euclidean dd/ds"]);
  for (const plot of sw.plots) {
    assert.equal(plot.x.length, 121);
    for (const y of plot.y) assert.ok(y.every((v) => Number.isFinite(v)), "every sample finite");
  }
  const legend = await page.locator("#bottom .u-legend").allTextContents();
  assert.ok(legend.join(" ").includes("GAP D") && legend.join(" ").includes("Euclidean d"), "the plot legend names both series");
  await screenshot(page, "gap-initial");
  assert.deepEqual(page.problems, []);
  await page.context().close();
});

test("a real drag on the gizmo changes D; the readout equals a direct POST for the URL's state; latency", async () => {
  const page = await openView(env.browser, env.server, "#/gap");
  await settled(page);
  const before = await hook(page, "result()");
  const requests0 = await hook(page, "requests()");
  const lat0 = (await hook(page, "latencies()")).length;
  const rt0 = (await hook(page, "roundTrips()")).length;
  const { at, dir } = await grabGizmo(page, "X");
  await page.mouse.down();
  const steps = 40;
  for (let i = 1; i <= steps; i++) {
    await page.mouse.move(at.x + dir.x * 2 * i, at.y + dir.y * 2 * i);
    await page.waitForTimeout(16); // about one pointer event per frame, as a hand produces
  }
  await page.mouse.up();
  await settled(page);
  const afterDrag = await hook(page, "result()");
  const state = await urlState(page);
  assert.ok(state.b.position[0] > 0.55 + 0.02, `B moved along +x (x = ${state.b.position[0]})`);
  assert.notEqual(afterDrag.distance, before.distance, "D changed");
  assert.ok(afterDrag.distance > before.distance, "moving B away from A increases D");
  const sent = (await hook(page, "requests()")) - requests0;
  assert.ok(sent >= 2 && sent <= steps + 1, `requests are paced by the server (${sent} for ${steps} drag steps)`);

  // What the user reads equals the server's answer for the state in the URL.
  const ref = await direct(state);
  const shown = await readoutNumbers(page);
  assert.equal(shown.D, ref.distance.toPrecision(6));
  assert.equal(shown.lambda, ref.lambda.toPrecision(6));
  assert.equal(shown.euclid, ref.euclidean.distance.toPrecision(6));
  assert.match(shown.iter, new RegExp(`^\\s*${ref.iterations} iterations \\(newton\\)`));
  await screenshot(page, "gap-after-drag");

  const lat = (await hook(page, "latencies()")).slice(lat0);
  const rt = (await hook(page, "roundTrips()")).slice(rt0);
  const sorted = [...lat].sort((a, b) => a - b);
  console.log(
    `drag step → readout: n=${lat.length} median ${median(lat).toFixed(1)} ms, p90 ${sorted[Math.floor(0.9 * sorted.length)].toFixed(1)} ms, max ${sorted.at(-1).toFixed(1)} ms; ${sent} requests for ${steps} steps; request round trip median ${median(rt).toFixed(1)} ms`,
  );
  assert.deepEqual(page.problems, []);
  await page.context().close();
});

test("measurement: drag → readout latency with the iso-surfaces hidden (rendering out of the way)", async () => {
  const light = { iso: { surfaces: "none", slice: "none" } };
  const page = await openView(env.browser, env.server, `#/gap?s=${encodeURIComponent(JSON.stringify(light))}`);
  await settled(page);
  const D0 = await hook(page, "D()");
  const n0 = (await hook(page, "latencies()")).length, r0 = (await hook(page, "roundTrips()")).length;
  const q0 = await hook(page, "requests()");
  const { at, dir } = await grabGizmo(page, "X");
  await page.mouse.down();
  for (let i = 1; i <= 60; i++) {
    await page.mouse.move(at.x + dir.x * i, at.y + dir.y * i);
    await page.waitForTimeout(16);
  }
  await page.mouse.up();
  await settled(page);
  assert.notEqual(await hook(page, "D()"), D0, "D changed");
  const lat = (await hook(page, "latencies()")).slice(n0), rt = (await hook(page, "roundTrips()")).slice(r0);
  const fs = await hook(page, "frameStats()");
  console.log(
    `light scene: drag step → readout n=${lat.length} median ${median(lat).toFixed(1)} ms; request round trip median ${median(rt).toFixed(1)} ms; ${(await hook(page, "requests()")) - q0} requests for 60 steps; frame median ${fs.medianMs.toFixed(1)} ms`,
  );
  assert.deepEqual(page.problems, []);
  await page.context().close();
});

test("refused parameters show the server's message; a good value turns the verdict green again", async () => {
  const page = await openView(env.browser, env.server, "#/gap");
  await settled(page);
  const input = (name) => page.locator(".lil-gui .lil-controller", { has: page.locator(".lil-name", { hasText: name }) }).locator("input");
  const verdict = page.locator("[data-testid=gap-verdict]");

  await input("h (eq. 4)").fill("0");
  await input("h (eq. 4)").press("Enter");
  await page.waitForFunction(() => document.querySelector("[data-testid=gap-verdict]")?.classList.contains("bad"));
  assert.match(await verdict.textContent(), /params\.h: h must be a finite number > 0/);
  assert.match(await page.locator(".gap-readout [data-field=error]").textContent(), /params\.h: h must be a finite number > 0/);
  assert.match((await page.locator(".toast-error").allTextContents()).join("\n"), /params\.h/);
  await input("h (eq. 4)").fill("0.1");
  await input("h (eq. 4)").press("Enter");
  await page.waitForFunction(() => document.querySelector("[data-testid=gap-verdict]")?.classList.contains("ok"));

  // ε = 0.3 breaks Property 2 on the pentagonal prism: the validator names the shape and the point.
  await input("ε (eq. 6)").fill("0.3");
  await input("ε (eq. 6)").press("Enter");
  await page.waitForFunction(() => document.querySelector("[data-testid=gap-verdict]")?.classList.contains("bad"));
  assert.match(await verdict.textContent(), /a: Property 2 fails: the Hessian of E_S has eigenvalue [0-9.]+ >= 1/);
  assert.equal(await hook(page, "D()"), null, "no stale number is reported as current");
  await screenshot(page, "gap-refused-params");
  await input("ε (eq. 6)").fill("0.01");
  await input("ε (eq. 6)").press("Enter");
  await page.waitForFunction(() => document.querySelector("[data-testid=gap-verdict]")?.classList.contains("ok"));
  await settled(page);
  // The browser logs each 400 response as a console error; nothing else may appear.
  const other = page.problems.filter((p) => !/status of 400/.test(p));
  assert.deepEqual(other, []);
  await page.context().close();
});

test("rotation sweep of parallel boxes: dD/ds is the derivative of D; the Euclidean one jumps, GAP's does not", async () => {
  const state = {
    a: { type: "box", size: [0.4, 0.4, 0.4], position: [0, 0, 0], quaternion: [1, 0, 0, 0] },
    b: { type: "box", size: [0.3, 0.3, 0.3], position: [0.6, 0.05, 0], quaternion: [1, 0, 0, 0] },
    sweep: { motion: "rotate", axis: "z", range: 0.3, samples: 121 },
  };
  const page = await openView(env.browser, env.server, `#/gap?s=${encodeURIComponent(JSON.stringify(state))}`);
  await settled(page);
  await page.waitForFunction(() => window.distlab.gap.sweep().data !== null, null, { timeout: 30000 });
  const { data } = await hook(page, "sweep()");
  const n = data.s.length, h = data.s[1] - data.s[0];
  // Central differences of D against the plotted derivative (gradient · axis): the error of a
  // central difference is h²/6 · |D'''|; bound |D'''| by the differences themselves.
  let worstGap = 0, scale = 0;
  for (let i = 1; i < n - 1; i++) {
    const fd = (data.gap[i + 1] - data.gap[i - 1]) / (2 * h);
    worstGap = Math.max(worstGap, Math.abs(fd - data.dGap[i]));
    scale = Math.max(scale, Math.abs(data.dGap[i]));
  }
  assert.ok(worstGap < 0.02 * scale, `GAP dD/ds matches the finite difference of D (worst ${worstGap.toExponential(2)}, scale ${scale.toExponential(2)})`);
  const maxJump = (y) => Math.max(...y.slice(1).map((v, i) => Math.abs(v - y[i])));
  const jumpE = maxJump(data.dEuclid), jumpG = maxJump(data.dGap);
  assert.ok(jumpE > 0.1, `the Euclidean derivative jumps where the faces are parallel (${jumpE.toFixed(3)})`);
  assert.ok(jumpG < jumpE / 10, `GAP's derivative stays continuous (largest step ${jumpG.toExponential(2)})`);
  await screenshot(page, "gap-rotation-sweep");
  assert.deepEqual(page.problems, []);
  await page.context().close();
});

test("a shared URL restores the same shapes and D; frames while orbiting", async () => {
  const page = await openView(env.browser, env.server, "#/gap");
  await settled(page);
  // Change something the URL must carry: B's type and size, the pose by keyboard nudges, σ.
  await page.locator(".lil-gui .lil-controller", { has: page.locator(".lil-name", { hasText: "radius (pentagon)" }) }).locator("input").fill("0.22");
  await page.keyboard.press("Enter");
  await page.mouse.click(5, 300); // leave the input
  for (let i = 0; i < 3; i++) await page.keyboard.press("ArrowUp");
  await page.keyboard.press("e"); // rotate mode
  await settled(page);
  const url = await page.evaluate(() => location.href);
  const state = await urlState(page);
  assert.equal(state.a.radius, 0.22);
  assert.ok(Math.abs(state.b.position[1] - 0.13) < 1e-9, `three 1 cm nudges along +y (y = ${state.b.position[1]})`);
  const D = await hook(page, "D()");
  const text = await hook(page, "readout()");

  const page2 = await openView(env.browser, env.server, url.slice(url.indexOf("#")));
  await settled(page2);
  assert.deepEqual(await hook(page2, "state()"), await hook(page, "state()"));
  assert.equal(await hook(page2, "D()"), D);
  assert.equal(await hook(page2, "readout()"), text);
  await screenshot(page2, "gap-restored");

  // Orbit: drag on an empty part of the canvas (upper right, away from the shapes).
  const box = await page2.locator("canvas.viewport-canvas").boundingBox();
  const before = await canvasPixels(page2);
  await page2.evaluate(() => window.distlab.gap.resetFrameStats());
  const x0 = box.x + box.width * 0.85, y0 = box.y + box.height * 0.2;
  await page2.mouse.move(x0, y0);
  await page2.mouse.down();
  for (let i = 0; i < 90; i++) {
    await page2.mouse.move(x0 - 3 * i, y0 + Math.sin(i / 10) * 20);
    await page2.waitForTimeout(8);
  }
  await page2.mouse.up();
  const fs = await hook(page2, "frameStats()");
  console.log(`orbiting: ${fs.frames} frames, median ${fs.medianMs.toFixed(1)} ms (${(1000 / fs.medianMs).toFixed(0)} fps), p95 ${fs.p95Ms.toFixed(1)} ms, ${fs.triangles} triangles`);
  assert.ok(differentBytes(before, await canvasPixels(page2)) > 0, "orbiting changed the picture");
  assert.deepEqual(page.problems, []);
  assert.deepEqual(page2.problems, []);
  await page.context().close();
  await page2.context().close();
});

/** The explorer with h set to `value` through its field (Enter), until the verdict says ok or bad. */
async function setH(page, value, verdict) {
  const input = page.locator(".lil-gui .lil-controller", { has: page.locator(".lil-name", { hasText: "h (eq. 4)" }) }).locator("input");
  await input.fill(String(value));
  await input.press("Enter");
  await page.waitForFunction((v) => document.querySelector("[data-testid=gap-verdict]")?.classList.contains(v), verdict);
}

test("an error toast goes once the value it is about is valid again", async () => {
  const page = await openView(env.browser, env.server, "#/gap");
  await settled(page);
  await setH(page, 0, "bad");
  assert.match((await page.locator(".toast-error").allTextContents()).join("\n"), /params\.h/);
  // Fixed: the next distance succeeds and the toast about h goes with it (it lived 8 s before).
  await setH(page, 0.1, "ok");
  const about = (await page.locator(".toast-error").allTextContents()).filter((t) => /params\.h/.test(t));
  assert.deepEqual(about, [], "no error toast about h once h is valid");
  // A level list typed wrong: its toast goes when the list is valid.
  const levels = page.locator(".lil-gui .lil-controller", { has: page.locator(".lil-name", { hasText: /^E_S levels$/ }) }).locator("input");
  await levels.fill("0.002, x");
  await levels.press("Enter");
  await page.locator(".toast-error", { hasText: "E_S levels" }).waitFor();
  await levels.fill("0.002, 0.004");
  await levels.press("Enter");
  assert.equal(await page.locator(".toast-error", { hasText: "E_S levels" }).count(), 0, "no toast about the levels once they are valid");
  const other = page.problems.filter((p) => !/status of 400/.test(p));
  assert.deepEqual(other, []);
  await page.context().close();
});

test("a refused sweep marks the plots' curves stale until a sweep succeeds", async () => {
  const page = await openView(env.browser, env.server, "#/gap");
  await settled(page);
  await page.waitForFunction(() => window.distlab.gap.sweep().data !== null, null, { timeout: 60000 });
  const stale = () => hook(page, "sweep()").then((s) => s.plots.map((p) => p.stale ?? null));
  assert.deepEqual(await stale(), [null, null], "the first sweep's curves are current");
  const sweeps = (await hook(page, "sweep()")).requests;
  await setH(page, 0, "bad");
  // The sweep of h = 0 is refused too: the curves drawn are h = 0.1's and must say so.
  await page.waitForFunction((n) => window.distlab.gap.sweep().requests > n, sweeps);
  const marked = await page
    .waitForFunction(() => window.distlab.gap.sweep().plots.every((p) => p.stale), null, { timeout: 15000 })
    .then(
      () => true,
      () => false,
    );
  assert.ok(marked, "after the refused sweep, both plots are marked stale");
  for (const s of await stale()) assert.match(s, /refused: params\.h/);
  const marks = page.locator("#bottom .plot-stale");
  assert.equal(await marks.count(), 2);
  for (const m of await marks.all()) {
    assert.ok(await m.isVisible(), "the mark is over the curves");
    assert.match(await m.textContent(), /not updated — the sweep was refused: params\.h/);
  }
  await screenshot(page, "gap-sweep-stale");
  await setH(page, 0.1, "ok");
  await page.waitForFunction(() => window.distlab.gap.sweep().plots.every((p) => p.stale === null), null, { timeout: 60000 });
  for (const m of await marks.all()) assert.equal(await m.isVisible(), false, "the curves are current again");
  const other = page.problems.filter((p) => !/status of 400/.test(p));
  assert.deepEqual(other, []);
  await page.context().close();
});
