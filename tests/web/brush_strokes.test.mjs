// Many overlapping σ strokes with the page's default brush (radius 8 % and falloff 4 % of the
// object's size, stamps half a radius apart): σ stays between its value before and the brush
// value everywhere, every edit is applied by the server (none passes its σ range and is refused),
// and the iso-surfaces keep following σ. Before the brush painted towards its value by
// the convex rule (brush_stamp.ts), such strokes swung σ past ±300 within a few dozen strokes and
// the server refused every edit after that.
import { test } from "node:test";
import assert from "node:assert/strict";
import { PAINTING_WINDOW, kelvinStroke, openView, screenshot, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();
const hash = (state) => `#/kelvin?s=${encodeURIComponent(JSON.stringify(state))}`;
const K = (page, expr) => page.evaluate(`(() => { const k = window.distlab.kelvin; return ${expr}; })()`);
const waitReady = (page) => page.waitForFunction(() => window.distlab?.kelvin?.ready === true, null, { timeout: 120000, polling: 100 });

/** σ of the page's body at x, by the server's documented rule (openapi.json, Sigma): the constant,
 *  then each brush in order, added (value · w) or towards its value ((1 − w) σ + w value). */
function sigmaAt(body, x) {
  let s = body.constant ?? 0;
  for (const b of body.brushes ?? []) {
    const d = Math.hypot(x[0] - b.center[0], x[1] - b.center[1], x[2] - b.center[2]);
    const t = d <= b.radius ? 1 : b.falloff > 0 ? Math.min(1, Math.max(0, 1 - (d - b.radius) / b.falloff)) : 0;
    const w = t * t * (3 - 2 * t);
    s = b.mode === "towards" ? (1 - w) * s + w * b.value : s + w * b.value;
  }
  return s;
}

test("overlapping strokes at the default brush keep σ between the base and the brush value, and the iso-surfaces follow every one", async () => {
  const base = -0.5;
  const page = await openView(env.browser, env.server, hash({ object: "cube", lx: 0.1, levels: [0, 0.25], base }), PAINTING_WINDOW);
  try {
    await waitReady(page);
    const brush = (await K(page, "k.state")).brush;
    assert.ok(brush.radius > 0.1 && brush.falloff > 0.05 && brush.value === 1, `the default brush: ${JSON.stringify(brush)}`);
    let shown = await K(page, "k.shown");
    // 32 strokes across the cube's top face (z = 0.5), 4 rounds of 8: horizontal ones 0.1 apart
    // (less than the brush's radius), then diagonals over them, each round shifted.
    for (let round = 0; round < 4; round++) {
      for (let j = 0; j < 8; j++) {
        const y = -0.35 + 0.1 * j + 0.02 * round;
        const diagonal = round % 2 === 1;
        await kelvinStroke(page, diagonal ? [-0.4, y - 0.1, 0.5] : [-0.4, y, 0.5], diagonal ? [0.4, y + 0.1 - 0.2 * (j % 2), 0.5] : [0.4, y, 0.5], 10);
      }
      // Every edit was applied and the shells are those of the latest σ.
      await waitReady(page);
      assert.equal(await page.locator(".toast-error").count(), 0, `round ${round}: no σ edit refused (${await page.locator(".toast-error").allTextContents()})`);
      const sigma = await K(page, "k.sigma");
      const now = await K(page, "k.shown");
      assert.deepEqual(now.map((f) => f.sigma_version), [sigma.version, sigma.version], `round ${round}: the iso-surfaces show σ version ${sigma.version}`);
      if (round === 0) assert.ok(now.some((f, i) => f.hash !== shown[i].hash), "the first strokes changed the iso-surfaces");
      shown = now;
      // σ on the painted face and next to it, by the rule of the body the server holds.
      let lo = Infinity, hi = -Infinity;
      for (let i = 0; i <= 40; i++)
        for (let k = 0; k <= 40; k++)
          for (const x of [[-0.5 + i / 40, -0.5 + k / 40, 0.5], [-0.5 + i / 40, 0.5, 0.5 - k / 40]]) {
            const s = sigmaAt(sigma.body, x);
            lo = Math.min(lo, s);
            hi = Math.max(hi, s);
          }
      assert.ok(lo >= base - 1e-9 && hi <= brush.value + 1e-9, `round ${round}: σ in [${lo}, ${hi}], outside [${base}, ${brush.value}]`);
      assert.ok(hi > brush.value - 1e-9, `round ${round}: the strokes painted the value`);
      const range = await K(page, "k.sigmaRange");
      assert.ok(range.data[0] >= base - 1e-6 && range.data[1] <= brush.value + 1e-6, `round ${round}: the page's σ on its display vertices ${JSON.stringify(range.data)}`);
    }
    // The server's σ at the input vertices is the page's.
    const fromServer = await page.evaluate(async (id) => {
      const f = await window.distlab.api.get(`/api/kelvin/objects/${id}/surface`);
      return Array.from(new Float32Array(f.scalars.slice().buffer));
    }, await K(page, "k.objectId"));
    const local = await K(page, "k.localSigmaAtInputVertices()");
    assert.equal(fromServer.length, local.length);
    fromServer.forEach((s, i) => assert.ok(Math.abs(s - local[i]) < 1e-5, `σ at vertex ${i}: server ${s}, page ${local[i]}`));
    await screenshot(page, "kelvin-overlapping-strokes");
    assert.deepEqual(page.problems, []);
  } finally {
    await page.context().close();
  }
});
