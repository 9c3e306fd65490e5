// Pictures that can be read (issue 17, items 5, 8, 11, 14): colour bars with ticks, units and
// ranges beside every colour-mapped quantity, colormap and range controls, σ's histogram; values
// with units under the pointer; painting through translucent shells; links of many σ strokes
// within a URL's budget, and σ saved to and loaded from a file in the wrench cases' format.
import { test } from "node:test";
import assert from "node:assert/strict";
import { createRequire } from "node:module";
import { readFileSync, writeFileSync } from "node:fs";
import path from "node:path";
import { pathToFileURL } from "node:url";
import { PAINTING_WINDOW, kelvinStroke, openView, screenStroke, screenshot, serverAndBrowser, tempDir } from "./harness.mjs";

const env = serverAndBrowser();
const source = process.env.DISTLAB_SOURCE_DIR ?? path.resolve(import.meta.dirname, "../..");
const require = createRequire(path.join(source, "web", "package.json"));
// The colour maps' definitions, independently of the page's look-up tables.
const chroma = await import(pathToFileURL(require.resolve("d3-scale-chromatic")).href);
const rgbOf = (css) => {
  const m = /^#(..)(..)(..)$/.exec(css);
  return m ? m.slice(1).map((h) => parseInt(h, 16)) : css.match(/\d+/g).slice(0, 3).map(Number);
};
const coolwarm = (t) => rgbOf(chroma.interpolateRdBu(1 - t));
const viridis = (t) => rgbOf(chroma.interpolateViridis(t));
const magma = (t) => rgbOf(chroma.interpolateMagma(t));
/** Centred (diverging) normalisation: 0 in the middle, each half of the range linear. */
const centred = (v, lo, hi) => Math.min(1, Math.max(0, v < 0 ? 0.5 - (0.5 * v) / lo : 0.5 + (0.5 * v) / hi));
const closeRgb = (a, b, tol, what) => assert.ok(a.every((x, i) => Math.abs(x - b[i]) <= tol), `${what}: ${a} vs ${b}`);

const hash = (view, state) => `#/${view}?s=${encodeURIComponent(JSON.stringify(state))}`;
const K = (page, expr) => page.evaluate(`(() => { const k = window.distlab.kelvin; return ${expr}; })()`);
const waitReady = (page) => page.waitForFunction(() => window.distlab?.kelvin?.ready === true, null, { timeout: 120000, polling: 100 });

const stroke = (page, from, to, steps = 8) => kelvinStroke(page, from, to, steps);

/** A lil-gui controller by its name inside the folder of the given title. */
const control = (page, folder, name) =>
  page
    .locator(".lil-gui", { has: page.locator(":scope > .lil-title", { hasText: folder }) })
    .last()
    .locator(".lil-controller", { has: page.locator(".lil-name", { hasText: name }) })
    .first();
async function setNumber(page, folder, name, value) {
  const input = control(page, folder, name).locator("input");
  await input.fill(String(value));
  await input.press("Enter");
}

/** The colour bar's pixel for value v of its range (its canvas: 256 rows, the top row the high end). */
const barPixel = (page, testid, v, range) =>
  page.evaluate(
    ([id, v, [lo, hi]]) => {
      const y = Math.min(255, Math.max(0, Math.round(((hi - v) / (hi - lo)) * 255)));
      return Array.from(document.querySelector(`[data-testid=${id}] canvas`).getContext("2d").getImageData(0, y, 1, 1).data.slice(0, 3));
    },
    [testid, v, range],
  );
const tickTexts = async (page, testid) => (await page.locator(`[data-testid=${testid}] .colorbar-tick`).allTextContents()).map(Number);

test("Kelvin: colour bars for σ and the slice's h, the surface coloured as its bar says, colormap and range controls, σ's histogram", async () => {
  const page = await openView(env.browser, env.server, hash("kelvin", { object: "cube", lx: 0.1, levels: [0.25], base: -0.5, slice: { show: true, axis: "z", offset: 0 } }));
  try {
    await waitReady(page);
    await page.waitForFunction(() => window.distlab.kelvin.colorbars.length === 2, null, { timeout: 60000 });
    let [sb, hb] = await K(page, "k.colorbars");
    assert.equal(sb.title, "σ on the surface");
    assert.equal(sb.unit, "dimensionless");
    assert.deepEqual(sb.dataRange, [-0.5, -0.5], "σ is the base constant everywhere");
    assert.deepEqual(sb.range, [-0.5, 0.5], "symmetric by default: ±max|σ|");
    assert.match(await page.locator("[data-testid=colorbar-sigma]").textContent(), /σ on the surface \(dimensionless\)/);
    const ticks = await tickTexts(page, "colorbar-sigma");
    assert.ok(ticks.length >= 3 && ticks.includes(0) && ticks.every((t) => t >= -0.5 && t <= 0.5), `σ ticks ${ticks}`);
    assert.match(hb.unit, /dimensionless/);
    const m = Math.max(...hb.dataRange.map(Math.abs));
    assert.deepEqual(hb.range, [-m, m], "h's symmetric range");
    assert.ok(hb.dataRange[0] < 0 && hb.dataRange[1] > 0, "h takes both signs on the slice (σ < 0 on the surface)");
    const hTicks = await tickTexts(page, "colorbar-h");
    assert.ok(hTicks.length >= 3 && hTicks.every((t) => t >= -m && t <= m), `h ticks ${hTicks}`);
    // The surface's colour is the map's at σ's place in the bar's range (d3's RdBu, blue for −).
    let cols = await K(page, "k.surfaceColors(97)");
    for (const s of cols.samples) closeRgb(s.rgb, coolwarm(centred(s.sigma, -0.5, 0.5)), 3, `σ ${s.sigma}`);
    closeRgb(await barPixel(page, "colorbar-sigma", -0.5, sb.range), coolwarm(0), 3, "the bar's bottom");

    // Paint σ = 1: the range follows (symmetric ±1), the surface's colours and the histogram too.
    await stroke(page, [-0.3, -0.1, 0.5], [0.3, 0.1, 0.5]);
    await page.waitForFunction(() => window.distlab.kelvin.sigma.body.brushes?.length > 0 && window.distlab.kelvin.ready, null, { timeout: 60000 });
    [sb] = await K(page, "k.colorbars");
    cols = await K(page, "k.surfaceColors(1)");
    const top = Math.max(...cols.samples.map((s) => s.sigma));
    assert.ok(top >= 1, "the stroke painted σ ≥ 1");
    assert.deepEqual(sb.dataRange, [-0.5, top], "the bar's data range is σ's on the surface");
    assert.deepEqual(sb.range, [-top, top]);
    for (const s of cols.samples.filter((_, i) => i % 37 === 0)) closeRgb(s.rgb, coolwarm(centred(s.sigma, -top, top)), 3, `σ ${s.sigma}`);
    closeRgb(await barPixel(page, "colorbar-sigma", top, sb.range), coolwarm(1), 3, "the bar's top");
    closeRgb(await barPixel(page, "colorbar-sigma", 0, sb.range), coolwarm(0.5), 3, "the bar's 0");
    // The histogram counts every display vertex, in bins over σ's range (counted here again).
    const hist = await K(page, "k.sigmaHistogram");
    assert.equal(hist.total, cols.vertices);
    assert.equal(hist.counts.reduce((a, b) => a + b, 0), cols.vertices);
    assert.equal(hist.edges[0], -0.5);
    assert.ok(Math.abs(hist.edges.at(-1) - top) < 1e-12);
    const w = (top - -0.5) / hist.counts.length;
    const mine = new Array(hist.counts.length).fill(0);
    for (const s of cols.samples) mine[Math.min(mine.length - 1, Math.floor((s.sigma - hist.edges[0]) / w))]++;
    assert.deepEqual(hist.counts, mine);
    assert.match(await page.locator("[data-testid=sigma-histogram] .histogram-caption").textContent(), /σ \(dimensionless\)/);
    assert.equal(await page.locator("[data-testid=sigma-histogram] canvas").count(), 1, "drawn by uPlot");

    // A sequential map over a fixed range.
    await control(page, "σ colours", "colormap").locator("select").selectOption("viridis");
    await control(page, "σ colours", "range").locator("select").selectOption("fixed");
    await setNumber(page, "σ colours", "fixed min", -2);
    await setNumber(page, "σ colours", "fixed max", 2);
    await page.waitForFunction(() => window.distlab.kelvin.colorbars[0].range[0] === -2 && window.distlab.kelvin.colorbars[0].range[1] === 2);
    [sb] = await K(page, "k.colorbars");
    assert.equal(sb.map, "viridis");
    cols = await K(page, "k.surfaceColors(53)");
    for (const s of cols.samples) closeRgb(s.rgb, viridis(Math.min(1, (s.sigma + 2) / 4)), 3, `viridis σ ${s.sigma}`);
    assert.deepEqual(await tickTexts(page, "colorbar-sigma"), [-2, -1.5, -1, -0.5, 0, 0.5, 1, 1.5, 2]);
    assert.equal((await K(page, "k.state")).sigmaColor.map, "viridis", "the choice is in the link");
    // The slice: magma over its data's own range (auto).
    await control(page, "h colours", "colormap").locator("select").selectOption("magma");
    await control(page, "h colours", "range").locator("select").selectOption("auto");
    await page.waitForFunction(() => window.distlab.kelvin.colorbars[1].map === "magma");
    [, hb] = await K(page, "k.colorbars");
    assert.deepEqual(hb.range, hb.dataRange, "auto: the data's range");
    closeRgb(await barPixel(page, "colorbar-h", hb.range[1], hb.range), magma(1), 3, "magma's top");
    closeRgb(await barPixel(page, "colorbar-h", hb.range[0], hb.range), magma(0), 3, "magma's bottom");
    await screenshot(page, "pictures-kelvin-colorbars");
    assert.deepEqual(page.problems, []);
  } finally {
    await page.context().close();
  }
});

test("GAP: the slice's colour bar names e_S or E_S in m², follows the field and the range controls", async () => {
  const page = await openView(env.browser, env.server, "#/gap");
  try {
    await page.waitForFunction(() => window.distlab.gap.colorbar() !== null && window.distlab.gap.iso().slice === "strict", null, { timeout: 120000 });
    let bar = await page.evaluate(() => window.distlab.gap.colorbar());
    let iso = await page.evaluate(() => window.distlab.gap.iso());
    assert.match(bar.title, /^E_S/);
    assert.equal(bar.unit, "m²");
    assert.deepEqual(bar.range, iso.sliceRange, "the bar shows the slice's range");
    assert.deepEqual(bar.range, bar.dataRange, "auto: the data's range");
    closeRgb(await barPixel(page, "colorbar-gap", bar.range[1], bar.range), viridis(1), 3, "viridis' top");
    await page.locator(".lil-controller:has(.lil-name:text-is('slice field')) select").selectOption("weak");
    await page.waitForFunction(() => window.distlab.gap.colorbar()?.title.startsWith("e_S"));
    await control(page, "slice colours", "range").locator("select").selectOption("fixed");
    await setNumber(page, "slice colours", "fixed min", 0);
    await setNumber(page, "slice colours", "fixed max", 0.1);
    await page.waitForFunction(() => window.distlab.gap.colorbar()?.range[1] === 0.1);
    bar = await page.evaluate(() => window.distlab.gap.colorbar());
    iso = await page.evaluate(() => window.distlab.gap.iso());
    assert.deepEqual(bar.range, [0, 0.1]);
    assert.deepEqual(iso.sliceRange, [0, 0.1], "the slice is coloured over the fixed range");
    assert.match(await page.locator("[data-testid=colorbar-gap]").textContent(), /e_S on the slice \(weak, eq\. 5\) \(m²\)/);
    await screenshot(page, "pictures-gap-colorbar");
  } finally {
    await page.context().close();
  }
});

test("Kelvin: hovering the surface shows σ, h and |∇h| there with units; hovering the slice shows h", async () => {
  const page = await openView(env.browser, env.server, hash("kelvin", { object: "cube", lx: 0.1, levels: [0.25], base: -0.5, slice: { show: true, axis: "z", offset: 0 } }));
  try {
    await waitReady(page);
    const p = await K(page, "k.toScreen([0.1, -0.15, 0.5])"); // the top face
    await page.mouse.move(p.x - 3, p.y);
    await page.mouse.move(p.x, p.y);
    await page.waitForFunction(() => window.distlab.kelvin.probe?.on === "surface", null, { timeout: 30000 });
    // The reading and its text in one evaluation: a later answer (the first mouse move's) may replace both.
    const { r, text } = await K(page, "({ r: k.probe, text: document.querySelector('.kelvin-probe').textContent })");
    assert.equal(r.sigma, -0.5);
    assert.match(text, /on the surface/);
    assert.match(text, /σ = -0\.5000 \(dimensionless\)/);
    assert.match(text, /h = -?[\d.]+ \(dimensionless/);
    assert.match(text, /\|∇h\| = [\d.]+ m⁻¹/);
    // On the boundary h = σ (eq. 9); the read-out is the server's answer at the point it names.
    assert.ok(Math.abs(r.h - r.sigma) < 0.02, `h ${r.h} next to the surface where σ = ${r.sigma}`);
    const direct = await page.evaluate(([id, p]) => window.distlab.api.post(`/api/kelvin/objects/${id}/query`, { points: [p] }), [await K(page, "k.objectId"), r.point]);
    assert.equal(r.h, direct.h[0]);
    assert.equal(Number(/\|∇h\| = ([\d.]+)/.exec(text)[1]), Number(Math.hypot(...direct.gradient[0]).toFixed(4)));
    // The slice, beside the cube (shells off).
    await page.keyboard.press("i");
    const q = await K(page, "k.toScreen([0.85, -0.6, 0])");
    await page.mouse.move(q.x, q.y);
    await page.waitForFunction(() => window.distlab.kelvin.probe?.on === "slice", null, { timeout: 30000 });
    const { r: s, text: sliceText } = await K(page, "({ r: k.probe, text: document.querySelector('.kelvin-probe').textContent })");
    assert.ok(Math.abs(s.point[2]) < 1e-9, "a point of the plane z = 0");
    const d2 = await page.evaluate(([id, p]) => window.distlab.api.post(`/api/kelvin/objects/${id}/query`, { points: [p] }), [await K(page, "k.objectId"), s.point]);
    assert.equal(s.h, d2.h[0]);
    assert.match(sliceText, /on the slice[\s\S]*h = [\d.-]+ \(dimensionless/);
    await screenshot(page, "pictures-kelvin-hover");
  } finally {
    await page.context().close();
  }
});

test("GAP: hovering the slice shows E_S there in m², the value its colour shows", async () => {
  let sent = null; // the page's level-set request: the same shape and parameters are asked again below
  const page = await openView(env.browser, env.server, "#/gap", {
    setup: (p) => p.on("request", (r) => r.method() === "POST" && r.url().endsWith("/api/gap/levelsets") && (sent = r.postDataJSON())),
  });
  try {
    await page.waitForFunction(() => window.distlab.gap.colorbar() !== null, null, { timeout: 120000 });
    const p = await page.evaluate(() => window.distlab.gap.toScreen([-0.5, -0.35, 0]));
    await page.mouse.move(p.x - 2, p.y);
    await page.mouse.move(p.x, p.y);
    await page.waitForFunction(() => window.distlab.gap.sliceReading() !== null);
    const r = await page.evaluate(() => window.distlab.gap.sliceReading());
    assert.equal(r.field, "strict");
    assert.ok(Math.abs(r.point[2]) < 1e-9);
    assert.match(await page.locator("[data-testid=gap-slice-readout]").textContent(), /E_S \(strict, eq\. 6\) = [\d.e-]+ m²/);
    // The server's E_S at that point (a 3×3 plane centred on it): the read-out interpolates the
    // slice's grid bilinearly, whose error is below (h_u² + h_v²)/8 · max|∂²E_S| with ∂²E_S/∂p² < I
    // (Property 2). (The slice drawn half a cell off its samples missed this by 20 times.)
    const pageRequest = structuredClone(sent); // (the request below is seen by the listener too)
    const exact = await page.evaluate(async ([sent, point]) => {
      const body = { ...sent, levels: { weak: [], strict: [] }, plane: { center: point, normal: [0, 0, 1], size: [1e-6, 1e-6], resolution: [3, 3] } };
      const out = await window.distlab.api.msgpack("POST", "/api/gap/levelsets", body);
      const b = out.plane.strict;
      return new Float32Array(b.slice().buffer)[4];
    }, [pageRequest, r.point]);
    const [hu, hv] = [0, 1].map((i) => pageRequest.plane.size[i] / (pageRequest.plane.resolution[i] - 1)); // the nodes' spacing
    assert.ok(Math.abs(r.value - exact) <= (hu * hu + hv * hv) / 8 + 1e-6 * Math.abs(exact), `read-out ${r.value}, server ${exact}`);
  } finally {
    await page.context().close();
  }
});

test("Kelvin: the brush paints through translucent iso-shells (and does not orbit)", async () => {
  const page = await openView(env.browser, env.server, hash("kelvin", { object: "cube", lx: 0.1, levels: [0.1, 0.25], base: -0.5, opacity: 0.9 }));
  try {
    await waitReady(page);
    const a = await K(page, "k.toScreen([-0.3, 0, 0.5])");
    const hits = await K(page, `k.pickAt(${a.x}, ${a.y})`);
    assert.ok(hits.indexOf("surface") > 0 && hits[0].startsWith("iso"), `the shells are in front of the surface there: ${hits}`);
    const camera = await K(page, "k.toScreen([0, 0, 0])");
    await stroke(page, [-0.3, 0, 0.5], [0.3, 0, 0.5]);
    await page.waitForFunction(() => window.distlab.kelvin.sigma.body.brushes?.length > 0, null, { timeout: 30000 });
    assert.deepEqual(await K(page, "k.toScreen([0, 0, 0])"), camera, "the camera did not orbit");
    const brushes = (await K(page, "k.sigma")).body.brushes;
    assert.ok(brushes.every((b) => Math.abs(b.center[2] - 0.5) < 1e-6), "the stamps are on the cube's top face, not on a shell");
  } finally {
    await page.context().close();
  }
});

test("Kelvin: a link with 200 σ strokes stays within 8 KB; σ saves to and loads from a case-format file that restores it exactly (the same iso-surface)", async (t) => {
  // Strokes that do not overlap (a brush of 3 cm + 1 cm on a grid of 10 × 20 strokes on the top
  // face), so that no stamp is skipped for changing nothing: the link holds every stroke's stamps.
  const brush = { on: true, value: 1, radius: 0.03, falloff: 0.01 };
  const page = await openView(env.browser, env.server, hash("kelvin", { object: "cube", lx: 0.1, levels: [0.25], base: -0.5, brush }), PAINTING_WINDOW);
  const downloads = tempDir(t, "distlab-sigma-");
  try {
    await waitReady(page);
    const lengths = {};
    // The strokes' screen positions in one call: the camera does not move while painting.
    const ends = Array.from({ length: 200 }, (_, s) => {
      const x = -0.45 + 0.1 * (s % 10), y = -0.475 + 0.05 * Math.floor(s / 10);
      return [[x, y, 0.5], [x + 0.06, y, 0.5]];
    });
    const screens = await page.evaluate((ends) => ends.map((e) => e.map((p) => window.distlab.kelvin.toScreen(p))), ends);
    for (let s = 0; s < 200; s++) {
      await screenStroke(page, ...screens[s], 3);
      if (s === 19) {
        // 20 strokes: all in the (plain) link; opening it gives the same σ.
        await page.waitForTimeout(400);
        const url = page.url();
        lengths.strokes20 = url.length;
        const again = await openView(env.browser, env.server, url.slice(url.indexOf("#")));
        await again.waitForFunction(() => window.distlab.kelvin.sigma.body.brushes?.length > 0);
        // The page paints with the link's brushes (5 digits), so the link is its σ exactly.
        assert.deepEqual((await K(again, "k.sigma")).body.brushes, (await K(page, "k.sigma")).body.brushes);
        await again.context().close();
      }
    }
    await page.waitForFunction(() => window.distlab.kelvin.ready, null, { timeout: 120000 });
    await page.waitForTimeout(1000);
    assert.equal(await page.locator(".toast-error").count(), 0, "every σ was applied");
    const shells = (await K(page, "k.shown")).map((f) => f.hash);
    const body = (await K(page, "k.sigma")).body;
    const url = page.url();
    const plain = `${url.split("#")[0]}${hash("kelvin", await K(page, "k.state"))}`;
    lengths.stamps = body.brushes.length;
    lengths.plain200 = plain.length;
    lengths.link200 = url.length;
    console.log(`σ link lengths: ${JSON.stringify(lengths)}`);
    assert.ok(url.length <= 8192, `the link is ${url.length} characters`);
    assert.ok(plain.length > 8192 && /#\/kelvin\?z=/.test(url), "the plain link would be over 8 KB: compressed");
    // Save the file; its content is the case format with every stamp at full precision.
    const [download] = await Promise.all([page.waitForEvent("download"), page.locator(".lil-function button", { hasText: "save σ file" }).click()]);
    const file = path.join(downloads, download.suggestedFilename());
    await download.saveAs(file);
    const saved = JSON.parse(readFileSync(file, "utf8"));
    assert.deepEqual(Object.keys(saved), ["comment", "mesh", "lx", "sigma"]);
    assert.deepEqual(saved.mesh, { asset: "cube" });
    assert.equal(saved.lx, 0.1);
    assert.deepEqual(saved.sigma, body, "the page's σ body");
    // The link names the file when its brushes do not fit; loading the file restores σ exactly,
    // and the server's iso-surface of it is the same surface (its digest).
    const other = await openView(env.browser, env.server, url.slice(url.indexOf("#")));
    await other.waitForFunction(() => window.distlab.kelvin.ready, null, { timeout: 120000 });
    if (/sigmaFile/.test(decodeURIComponent(url)) || !/z=/.test(url)) {
      assert.match(await other.locator("[data-testid=kelvin-sigma-notice]").textContent(), new RegExp(`${body.brushes.length} brush stamps`));
    }
    await other.setInputFiles("input[data-testid=kelvin-sigma-file]", file);
    // (The link's own brushes, rounded, may be as many: wait for the file's, at full precision.)
    await other.waitForFunction((b) => JSON.stringify(window.distlab.kelvin.sigma.body) === b && window.distlab.kelvin.ready, JSON.stringify(body), { timeout: 120000 });
    assert.deepEqual((await K(other, "k.sigma")).body, body);
    assert.deepEqual((await K(other, "k.shown")).map((f) => f.hash), shells, "the server's iso-surface of it is the same");
    assert.equal(await other.locator("[data-testid=kelvin-sigma-notice]").isHidden(), true);
    // A wrong file is refused, naming the field.
    const bad = path.join(downloads, "bad.json");
    writeFileSync(bad, JSON.stringify({ ...saved, sigma: { ...saved.sigma, colour: 1 } }));
    await other.setInputFiles("input[data-testid=kelvin-sigma-file]", bad);
    assert.match(await other.locator(".toast-error").last().textContent(), /sigma\.colour: unknown key/);
    // The project's own case file reads as the preset it is.
    const parsed = await other.evaluate(async (text) => {
      const f = new File([text], "wrench_case_a.json");
      const input = document.querySelector("input[data-testid=kelvin-sigma-file]");
      const dt = new DataTransfer();
      dt.items.add(f);
      input.files = dt.files;
      input.dispatchEvent(new Event("change"));
      await new Promise((r) => setTimeout(r, 500));
      return window.distlab.kelvin.state;
    }, readFileSync(path.join(source, "assets", "wrench_case_a.json"), "utf8"));
    assert.equal(parsed.object, "wrench");
    assert.equal(parsed.preset, "a", "its axis term is case (a)'s");
    assert.equal(parsed.lx, 0.002);
    await other.context().close();
    await screenshot(page, "pictures-kelvin-200-strokes");
  } finally {
    await page.context().close();
  }
});
