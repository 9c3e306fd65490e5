// The Kelvin view's iso-surface shells over the σ paint (issue 37, item 5): σ's colours read
// through the shells as without them (the shells no longer tint the paint patch by patch), and a
// legend lists every shell drawn with its level and colour.
import { test } from "node:test";
import assert from "node:assert/strict";
import { createRequire } from "node:module";
import path from "node:path";
import { pathToFileURL } from "node:url";
import { openView, pagePixels, screenshot, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();
const source = process.env.DISTLAB_SOURCE_DIR ?? path.resolve(import.meta.dirname, "../..");
const require = createRequire(path.join(source, "web", "package.json"));
const chroma = await import(pathToFileURL(require.resolve("d3-scale-chromatic")).href);
/** The view's σ map (coolwarm: d3's RdBu reversed) at t ∈ [0, 1], as bytes. */
const coolwarm = (t) => chroma.interpolateRdBu(1 - t).match(/\d+/g).slice(0, 3).map(Number);

const hash = (state) => `#/kelvin?s=${encodeURIComponent(JSON.stringify(state))}`;
const K = (page, expr) => page.evaluate(`(() => { const k = window.distlab.kelvin; return ${expr}; })()`);
const waitReady = (page) => page.waitForFunction(() => window.distlab?.kelvin?.ready === true, null, { timeout: 120000, polling: 100 });

/** σ = −0.5 + 1.5 = 1 on a disc of radius 0.35 (falloff 0.05) of the cube's face z = 0.5 (in
 *  view), −0.5 elsewhere: the shells h = 0, 0.25 and 0.5 meet the face along the disc's rim. */
const PAINTED = { object: "cube", lx: 0.1, base: -0.5, levels: [0, 0.25, 0.5], brushes: [[0, 0, 0.5, 0.35, 1.5, 0.05]] };

/** The canvas's pixels (sRGB bytes) at the page positions of world points. */
async function pixelsAt(page, points) {
  await page.mouse.move(2, 790); // no hover read-out or brush ring over the samples
  await page.waitForTimeout(600);
  const at = [];
  for (const p of points) at.push(await K(page, `k.toScreen(${JSON.stringify(p)})`));
  return pagePixels(page, at);
}

const maxChannel = (a, b) => Math.max(...a.map((v, k) => Math.abs(v - b[k])));

test("σ paint reads through the iso-surface shells: no sample changes by σ's colour step for Δσ = 0.25 or more", async () => {
  const page = await openView(env.browser, env.server, hash(PAINTED));
  try {
    await waitReady(page);
    assert.deepEqual((await K(page, "k.shown")).map((s) => s.level), [0, 0.25, 0.5], "three shells drawn");
    // Samples well inside the disc (σ = 1 there, 0.1 inside the falloff).
    const points = [];
    for (let x = -0.2; x <= 0.2001; x += 0.05) for (let y = -0.2; y <= 0.2001; y += 0.05) if (Math.hypot(x, y) <= 0.2001) points.push([x, y, 0.5]);
    const seen = [];
    for (const p of points) {
      const s = await K(page, `k.toScreen(${JSON.stringify(p)})`);
      seen.push((await K(page, `k.pickAt(${s.x}, ${s.y})`)).filter((h) => !h.startsWith("iso"))[0]);
    }
    assert.ok(seen.every((h) => h === "surface"), `the samples are on the surface in view: ${seen}`);
    const withShells = await pixelsAt(page, points);
    await screenshot(page, "kelvin-paint-through-shells");
    await page.keyboard.press("i"); // shells off
    await page.waitForFunction(() => window.distlab.kelvin.state.showIso === false);
    const without = await pixelsAt(page, points);
    // Without shells, σ = 1 everywhere there: one colour (lighting of one flat face).
    const spread = Math.max(...[0, 1, 2].map((k) => Math.max(...without.map((c) => c[k])) - Math.min(...without.map((c) => c[k]))));
    assert.ok(spread <= 12, `the samples are one colour without the shells (spread ${spread})`);
    assert.ok(without.every((c) => c[0] > 2 * c[2]), `σ = 1's red without the shells: ${without[0]}`);
    // σ's colour step for a change of 0.25 (the map's step from 1 to 0.75 over the symmetric range
    // ±1), scaled by this face's lighting (its σ = 1 red against the map's).
    const [bar] = await K(page, "k.colorbars");
    assert.deepEqual(bar.range, [-1, 1]);
    const top = coolwarm(1), next = coolwarm(0.875);
    const light = Math.min(1, without.reduce((s, c) => s + c[0], 0) / without.length / top[0]);
    const step = light * maxChannel(top, next);
    const diffs = withShells.map((c, i) => maxChannel(c, without[i]));
    const mean = diffs.reduce((a, b) => a + b, 0) / diffs.length;
    console.log(`shell tint on the paint: mean ${mean.toFixed(1)}, largest ${Math.max(...diffs)} (of 255); σ's step for Δσ = 0.25 here: ${step.toFixed(1)}`);
    diffs.forEach((d, i) => assert.ok(d < step, `at ${points[i]}: the shells change the paint by ${d} (σ's step for 0.25: ${step.toFixed(1)}); with ${withShells[i]}, without ${without[i]}`));
    assert.deepEqual(page.problems, []);
  } finally {
    await page.context().close();
  }
});

test("the iso-surface shells have a legend: every level shown with its shell's colour; it follows the levels and hides with the shells", async () => {
  const page = await openView(env.browser, env.server, hash({ object: "cube", lx: 0.1, base: -0.5, levels: [0, 0.25, 0.5] }));
  try {
    await waitReady(page);
    const legend = page.locator("[data-testid=iso-legend]");
    await legend.waitFor({ state: "visible" });
    const rows = async () =>
      legend.locator(".iso-legend-row").evaluateAll((els) =>
        els.map((e) => ({ text: e.textContent, level: Number(e.dataset.level), color: getComputedStyle(e.querySelector(".iso-legend-swatch")).backgroundColor })),
      );
    const rgb = (hex) => `rgb(${[1, 3, 5].map((i) => parseInt(hex.slice(i, i + 2), 16)).join(", ")})`;
    const check = async (levels) => {
      await page.waitForFunction((n) => window.distlab.kelvin.ready && window.distlab.kelvin.shells.length === n, levels.length, { timeout: 120000 });
      const shells = await K(page, "k.shells");
      const shown = await rows();
      assert.deepEqual(shown.map((r) => r.level), levels, "one row per level, in order");
      for (const r of shown) {
        const shell = shells.find((s) => s.level === r.level);
        assert.equal(r.color, rgb(shell.color), `h = ${r.level}: the swatch is the shell's colour`);
        assert.match(r.text, new RegExp(`h = ${r.level}\\b`));
        assert.doesNotMatch(r.text, /computing/, "its shell is drawn");
      }
      const colors = new Set(shown.map((r) => r.color));
      assert.equal(colors.size, levels.length, "each level its own colour");
    };
    await check([0, 0.25, 0.5]);
    assert.match(await legend.textContent(), /iso-surfaces of h \(dimensionless\)/);
    assert.match(await legend.textContent(), /h = 0 \(zero level set\)/);
    // Other levels: typed in the panel.
    const input = page
      .locator(".lil-gui", { has: page.locator(":scope > .lil-title", { hasText: "Iso-surfaces of h" }) })
      .last()
      .locator(".lil-controller", { has: page.locator(".lil-name", { hasText: /^levels$/ }) })
      .locator("input");
    await input.fill("0.1, 0.3");
    await input.press("Enter");
    await check([0.1, 0.3]);
    await screenshot(page, "kelvin-iso-legend");
    await page.keyboard.press("i");
    await legend.waitFor({ state: "hidden" });
    assert.deepEqual(page.problems, []);
  } finally {
    await page.context().close();
  }
});
