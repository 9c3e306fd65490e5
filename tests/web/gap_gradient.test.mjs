// The gradient of D in the GAP explorer (issue 37, item 4): the readout's ∂D/∂p and ∂D/∂θ of both
// shapes are the central differences of D computed through the HTTP API (each shape moved by ±h
// along x, y, z and turned by ±h about them, about its own origin in the world frame); the arrows
// drawn start at the witness points and origins the readout gives and are the legend's scale
// times the readout's numbers; the display toggles and the scale are in the link.
import { test } from "node:test";
import assert from "node:assert/strict";
import { hook, settled, shapeFromUrl, urlState } from "./gap_page.mjs";
import { openView, pagePixels, screenshot, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();

const hash = (state) => `#/gap?s=${encodeURIComponent(JSON.stringify(state))}`;

/** A separated pair, both turned about an oblique axis (every angular component non-zero). */
const turned = (angle, axis) => {
  const n = Math.hypot(...axis);
  return [Math.cos(angle / 2), ...axis.map((c) => (Math.sin(angle / 2) * c) / n)];
};
const STATE = {
  a: { type: "polytope", radius: 0.25, height: 0.3, size: [0.4, 0.4, 0.4], position: [0, 0, 0], quaternion: turned(0.3, [0.2, -0.5, 1]) },
  b: { type: "box", size: [0.3, 0.2, 0.25], radius: 0.15, height: 0.3, position: [0.6, 0.12, 0.07], quaternion: turned(0.5, [1, 2, 3]) },
};

/** q ⊗ p for [w, x, y, z]. */
function qmul(q, p) {
  const [w1, x1, y1, z1] = q, [w2, x2, y2, z2] = p;
  return [w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2, w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2];
}

/** D for a URL state's shapes with shape k moved: component i < 3 translates by t along axis i,
 *  i ≥ 3 turns by t about world axis i − 3 through the shape's origin. */
async function D(state, k, i, t) {
  const s = structuredClone(state);
  if (i < 3) s[k].position[i] += t;
  else {
    const e = [0, 0, 0];
    e[i - 3] = 1;
    s[k].quaternion = qmul(turned(t, e), s[k].quaternion);
  }
  const p = s.params;
  const r = await fetch(env.server.url + "api/gap/distance", {
    method: "POST",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ a: shapeFromUrl(s.a), b: shapeFromUrl(s.b), params: { h: p.h, k: p.k, eps: p.eps, sigma: p.sigma, solver: p.solver, gradient: false } }),
  });
  assert.equal(r.status, 200);
  const out = await r.json();
  assert.equal(out.overlap, false);
  return out.distance;
}

/** The numbers of a readout line "… = (x, y, z) unit". */
async function vector(page, field) {
  const text = (await page.locator(`.gap-readout [data-field=${field}]`).textContent()) ?? "";
  const m = /=\s*\(([^)]*)\)\s*(\S+)/.exec(text);
  assert.ok(m, `readout line ${field}: ${text}`);
  return { v: m[1].split(",").map(Number), unit: m[2] };
}

test("the readout's gradient of D is the finite difference of D through the API; the arrows are drawn from it", async () => {
  const page = await openView(env.browser, env.server, hash(STATE));
  await settled(page);
  const state = await hook(page, "state()"); // the link's shapes with the default parameters
  assert.deepEqual([state.a, state.b], [STATE.a, STATE.b]);
  assert.equal(state.display.gradient, true, "the gradient is shown by default");

  const shown = {};
  for (const k of ["a", "b"]) {
    const lin = await vector(page, `grad-${k}-linear`);
    const ang = await vector(page, `grad-${k}-angular`);
    assert.equal(lin.unit, "m/m", "∂D/∂p: metres of D per metre");
    assert.equal(ang.unit, "m/rad", "∂D/∂θ: metres of D per radian");
    shown[k] = [...lin.v, ...ang.v];
    assert.ok(shown[k].every(Number.isFinite), `six numbers for ${k}: ${shown[k]}`);
  }
  // Central differences with steps h and h/2: their difference bounds the truncation error of
  // the finer one (error ∝ h²: e(h/2) ≈ (fd(h) − fd(h/2)) / 3); the readout has 6 significant digits.
  const h = 1e-4;
  const report = [];
  for (const k of ["a", "b"])
    for (let i = 0; i < 6; i++) {
      const fd1 = (await D(state, k, i, h)) - (await D(state, k, i, -h));
      const fd2 = (await D(state, k, i, h / 2)) - (await D(state, k, i, -h / 2));
      const [c1, c2] = [fd1 / (2 * h), fd2 / h];
      const g = shown[k][i];
      const tol = Math.abs(c1 - c2) + 5e-6 * Math.abs(g) + 1e-7;
      report.push(`${k}[${i}] shown ${g} fd ${c2.toExponential(6)}`);
      assert.ok(Math.abs(c2 - g) <= tol, `gradient_${k}[${i}]: readout ${g}, (D+ − D−)/2h = ${c2} (tolerance ${tol.toExponential(2)})`);
    }
  console.log(report.join("; "));
  assert.ok(Math.abs(shown.b[0]) > 0.01 && shown.b.slice(3).every((w) => Math.abs(w) > 1e-4), "a gradient with every component to check");

  // The arrows: ∂D/∂p from the witness point, ∂D/∂θ's axis from the origin, k × the readout.
  const legend = async (part) => (await page.locator(`[data-testid=gap-legend-grad-${part}]`).textContent()) ?? "";
  const scaleOf = (text, unit) => {
    const m = new RegExp(`0\\.1 m of (?:arrow|axis) = ([0-9.e+-]+) ${unit}`).exec(text);
    assert.ok(m, `legend states the scale: ${text}`);
    return 0.1 / Number(m[1]);
  };
  const kLin = scaleOf(await legend("linear"), "m/m");
  const kAng = scaleOf(await legend("angular"), "m/rad");
  // Where D and a*, b* are read, the page says what they are not (a newcomer read D as d).
  const readout = (await page.locator(".gap-readout").textContent()) ?? "";
  assert.match(readout, /D is 0 on contact but not the Euclidean d/);
  assert.match(readout, /smooth witness points, off the surfaces/);
  const drawn = await hook(page, "arrows()");
  for (const k of ["a", "b"]) {
    const witness = (await vector(page, `gap-witness-${k}`)).v;
    const arrows = drawn[k];
    const close = (x, y, tol, what) => assert.ok(x.every((v, i) => Math.abs(v - y[i]) <= tol), `${what}: ${x} vs ${y}`);
    close(arrows.linear.origin, witness, 1e-5, `${k}'s ∂D/∂p arrow starts at its witness point`);
    const lin = arrows.linear.tip.map((v, i) => v - arrows.linear.origin[i]);
    close(lin, shown[k].slice(0, 3).map((g) => kLin * g), 1e-5 * kLin, `${k}'s ∂D/∂p arrow is ${kLin} m per m/m`);
    // Each linear arrow is named at its tip (both start at nearly the same point between the shapes).
    assert.equal(arrows.linear.label?.text, `∂D/∂p ${k.toUpperCase()}`);
    const beyond = arrows.linear.label.at.map((v, i) => v - arrows.linear.tip[i]);
    close(beyond, lin.map((v) => (0.02 * v) / Math.hypot(...lin)), 1e-6, `${k}'s label sits 2 cm beyond its tip`);
    close(arrows.angular.origin, state[k].position, 1e-9, `${k}'s ∂D/∂θ axis starts at its origin`);
    const ang = arrows.angular.tip.map((v, i) => v - arrows.angular.origin[i]);
    close(ang, shown[k].slice(3).map((g) => kAng * g), 1e-5 * kAng, `${k}'s ∂D/∂θ axis is ${kAng} m per m/rad`);
    const longest = Math.max(Math.hypot(...lin), Math.hypot(...ang));
    assert.ok(longest > 0.02 && longest < 0.5, `arrows of a readable length next to shapes of ~0.3 m (${longest.toFixed(3)} m)`);
  }
  await screenshot(page, "gap-gradient");
  assert.deepEqual(page.problems, []);
  await page.context().close();
});

test("the gradient toggle and the arrows' scale are in the link; off, no gradient is drawn or listed", async () => {
  const page = await openView(env.browser, env.server, hash(STATE));
  await settled(page);
  const control = (name) => page.locator(".lil-gui .lil-controller", { has: page.locator(".lil-name", { hasText: name }) });
  await control("∂D/∂p scale").locator("input").fill("0.5");
  await control("∂D/∂p scale").locator("input").press("Enter");
  await settled(page);
  assert.equal((await hook(page, "arrows()")).scales.linear, 0.5);
  assert.match(await page.locator("[data-testid=gap-legend-grad-linear]").textContent(), /0\.1 m of arrow = 0\.2 m\/m/);
  const scaled = await urlState(page);
  assert.equal(scaled.display.linearScale, 0.5);
  const again = await openView(env.browser, env.server, hash(scaled));
  await settled(again);
  assert.deepEqual(await hook(again, "arrows()"), await hook(page, "arrows()"), "the link draws the same arrows");
  await again.context().close();

  await control("show ∇D arrows").locator("input").uncheck();
  await page.waitForFunction(() => window.distlab.gap.arrows() === null);
  assert.equal(await page.locator(".gap-readout [data-field^=grad-]").count(), 0, "no gradient in the readout");
  await settled(page);
  const off = await urlState(page);
  assert.equal(off.display.gradient, false);
  // Opened elsewhere, the link shows no gradient and does not ask for one.
  const requests = [];
  const closed = await openView(env.browser, env.server, hash(off), {
    setup: (p) => p.on("request", (r) => r.url().endsWith("/api/gap/distance") && requests.push(JSON.parse(r.postData()))),
  });
  await settled(closed);
  assert.equal(await hook(closed, "arrows()"), null);
  assert.equal(await closed.locator("[data-testid=gap-legend-grad-linear]").isVisible(), false);
  assert.ok(requests.some((b) => b.a && b.params.gradient === false), "single-pair requests ask for no gradient");
  // Back on: the gradient is requested and drawn again.
  await control("show ∇D arrows").locator("input").check();
  await page.waitForFunction(() => window.distlab.gap.arrows() !== null);
  assert.deepEqual(page.problems, []);
  assert.deepEqual(closed.problems, []);
  await closed.context().close();
  await page.context().close();
});

// B's ∂D/∂θ is drawn from B's origin, where the transform handles of the selected shape (B by
// default) sit; the handles (TransformControls, drawn last) covered it (issue 37 leftover). The
// canvas at points along B's angular axis, away from its arc, shows the arrow's colour.
test("B's ∂D/∂θ axis is drawn over the transform handles at B's origin", async () => {
  const page = await openView(env.browser, env.server, hash(STATE));
  await settled(page);
  assert.equal(await hook(page, "selected()"), "b", "the handles are on B");
  const axis = (await hook(page, "arrows()")).b.angular;
  // Along the axis, short of its arc (0.6 of its length) and its head.
  const along = Array.from({ length: 36 }, (_, i) => 0.1 + (0.8 * i) / 35).filter((f) => f < 0.5 || (f > 0.72 && f < 0.85));
  const at = along.map((f) => axis.origin.map((o, i) => o + f * (axis.tip[i] - o)));
  const screen = [];
  for (const p of at) screen.push(await page.evaluate((q) => window.distlab.gap.toScreen(q), p));
  await page.mouse.move(2, 790); // no handle highlighted under the mouse
  await page.waitForTimeout(300);
  const arrow = [0x4d, 0xd0, 0xe1]; // GRADIENT_COLORS.angular
  const colours = await pagePixels(page, screen, arrow);
  for (const [k, c] of colours.entries()) assert.ok(c.every((v, i) => Math.abs(v - arrow[i]) <= 40), `at ${along[k].toFixed(2)} of the axis: ${c}, not the arrow's ${arrow}`);
  await screenshot(page, "gap-gradient-handles");
  assert.deepEqual(page.problems, []);
  await page.context().close();
});
