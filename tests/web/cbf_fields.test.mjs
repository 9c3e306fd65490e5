// A scenario with a Kelvin field in the CBF view (issue 33): wrench_grasp, listed by the server,
// run from the page against a server with an empty cache (the job prepares the field and the
// progress bar says so), its σ = 0 run overlaid ("compare with"). Checked: the object is drawn
// with σ painted, the shells of h = 0 and δ are in the scene (the overlaid run's tinted), the
// control points are in the scene coloured by h (red exactly where h < δ), h and the plots follow
// the records, the colour bars and legend name it all, hovering reads σ and h, and nothing logs an
// error. The shells' iso-levels chosen in the panel (or the link) are refetched and named, and
// levels the server refuses are reported while the shells drawn stay.
import { test } from "node:test";
import assert from "node:assert/strict";
import { C, hash } from "./cbf_page.mjs";
import { openView, screenshot, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();
const GREY = 0x9aa4ae; // a control point whose h is not known

// wrench_grasp in the CBF view, Euclidean, with the view settings `extra` (hash()).
function openWrench(extra) {
  return openView(
    env.browser,
    env.server,
    hash({ scenario: "wrench_grasp", metric: "euclidean", ...extra }),
  );
}

// The CBF view loaded its scenario and waits for "r" (run).
function viewReady(page) {
  return page.waitForFunction(
    () =>
      window.distlab?.cbf &&
      /press r/.test(document.getElementById("status")?.textContent ?? ""),
    null,
    { timeout: 60000 },
  );
}

test("wrench_grasp: the field is prepared with progress, drawn, and its σ = 0 run overlaid", async () => {
  const page = await openWrench({ compare: "sigma_zero", duration: 0.5 });
  await viewReady(page);
  const scenarios = await page.evaluate(() =>
    [...document.querySelectorAll("select")].flatMap((s) =>
      [...s.options].map((o) => o.value),
    ),
  );
  assert.ok(
    scenarios.includes("wrench_grasp"),
    "the scenario menu lists wrench_grasp",
  );
  assert.equal((await C(page, "c.robot")).name, "panda_hand");

  await page.keyboard.press("r");
  // The first rollout's job prepares the wrench's field (the server's cache is empty), the second
  // reads it from the cache and solves σ = 0.
  await page.waitForFunction(
    () => {
      const r = window.distlab.cbf.rollouts;
      return (
        r.length === 2 &&
        r.every((x) => ["finished", "cancelled", "failed"].includes(x.state)) &&
        document.getElementById("progress").hidden
      );
    },
    null,
    { timeout: 600000, polling: 50 },
  );
  const rollouts = await C(page, "c.rollouts");
  assert.deepEqual(
    rollouts.map((r) => [r.key, r.label, r.state]),
    [
      ["euclidean", "Euclidean", "finished"],
      ["euclidean2", "Euclidean, σ = 0", "finished"],
    ],
  );
  await page.waitForFunction(
    () =>
      Object.values(window.distlab.cbf.fields()).every(
        (w) => w.objects.length === 1,
      ),
    null,
    { timeout: 60000 },
  );

  const rec = {};
  for (const r of rollouts)
    rec[r.key] = await page.evaluate(
      (id) => window.distlab.api.get(`/api/cbf/rollouts/${id}/record`),
      r.id,
    );
  assert.ok(
    rec.euclidean.kelvin && rec.euclidean2.kelvin,
    "both records have the field part",
  );
  const fields = await C(page, "c.fields()");
  const [first, second] = [fields.euclidean, fields.euclidean2];
  // The object: the wrench as the file gives it, painted with σ (many colours) in the first world.
  const object = first.objects[0];
  assert.equal(object.name, "wrench");
  assert.equal(object.vertices, 584);
  assert.equal(object.faces, 1168);
  assert.ok(object.visible, "the object is drawn");
  assert.ok(object.colors > 20, `σ is painted (${object.colors} colours)`);
  assert.ok(
    object.sigmaRange[0] < -0.49 && object.sigmaRange[1] > 0.49,
    `σ of case (a): ${object.sigmaRange}`,
  );
  // The shells h = 0 and h = δ, translucent; the overlaid σ = 0 run's in its own tint, its object not drawn twice.
  assert.deepEqual(
    object.shells.map((s) => s.level),
    [0, 0.2],
  );
  for (const s of [...object.shells, ...second.objects[0].shells]) {
    assert.ok(
      s.faces > 1000 && s.visible && s.opacity < 1,
      `shell h = ${s.level}: ${JSON.stringify(s)}`,
    );
  }
  assert.ok(
    !second.objects[0].visible,
    "the overlaid run's object is hidden (the same mesh)",
  );
  assert.notEqual(
    second.objects[0].shells[0].color,
    object.shells[0].color,
    "the overlaid run's shells are tinted",
  );
  // σ = 0 moves the zero level set: the two runs' shells differ.
  assert.notEqual(second.objects[0].shells[0].faces, object.shells[0].faces);

  // The control points at the step drawn (the last), coloured by h: red exactly below δ, and h as the record has it.
  const step = await C(page, "c.step");
  for (const [key, w] of [
    ["euclidean", first],
    ["euclidean2", second],
  ]) {
    const h = rec[key].kelvin.fields[0].h[step];
    assert.equal(w.points.count, 72);
    assert.equal(w.points.h.length, 72);
    w.points.h.forEach((v, p) =>
      assert.equal(v, h[p], `${key} h at point ${p}`),
    );
    w.points.colors.forEach((c, p) => {
      assert.notEqual(c, GREY, `${key} point ${p} is coloured`);
      assert.equal(
        c === 0xff3b30,
        h[p] < 0.2,
        `${key} point ${p}: red iff h < δ`,
      );
    });
  }
  assert.ok(
    new Set(first.points.colors).size > 5,
    "h colours vary over the points",
  );

  // Colour bars: σ (the Kelvin view's map) and h with δ marked and red below it.
  const bars = await C(page, "c.colorbars");
  const sigmaBar = bars.find((b) => b.title === "σ on the object");
  const hBar = bars.find((b) => b.title === "h at the control points");
  assert.equal(sigmaBar.map, "coolwarm");
  assert.deepEqual(hBar.marks, [{ value: 0.2, label: "δ 0.2" }]);
  assert.deepEqual(hBar.below, { value: 0.2, color: "#ff3b30" });
  const legend = await page.locator('[data-testid="cbf-legend"]').textContent();
  for (const text of [
    "wrench: σ painted",
    "shell h = 0 (zero level set)",
    "shell h = 0.2",
    "Eucl σ=0: shell h = 0",
    "control points coloured by h",
  ])
    assert.ok(legend.includes(text), `legend: ${text}`);
  const readout = await page
    .locator('[data-testid="cbf-readout"]')
    .textContent();
  assert.match(
    readout,
    /wrench: min h [\d.]+ \(δ 0\.2\) at .*closest point σ 0\.50/,
  );

  // The field plots: min h over the points per step, and δ, as the record has them.
  const plots = await C(page, "c.plotsFields()");
  const minH = plots.h.y[plots.h.labels.indexOf("min h Eucl")];
  rec.euclidean.kelvin.fields[0].h.forEach((row, i) =>
    assert.equal(minH[i], Math.min(...row), `min h at step ${i}`),
  );
  assert.ok(
    plots.h.y[plots.h.labels.indexOf("δ Eucl")].every((v) => v === 0.2),
  );
  const safety = plots.distance.y[plots.distance.labels.indexOf("safety Eucl")];
  assert.ok(
    safety.every((v) => v === rec.euclidean.kelvin.fields[0].safety_distance),
  );

  // Hovering: σ on the handle, h at a control point.
  await page.keyboard.press("o"); // the camera on the object
  await page.waitForTimeout(500);
  const handle = await C(page, "c.toScreen([0.52, 0, 0.005])");
  await page.mouse.move(handle.x, handle.y);
  await page.waitForFunction(
    () => /wrench: σ/.test(window.distlab.cbf.hover ?? ""),
    null,
    { timeout: 10000 },
  );
  const sigmaHere = Number(/σ (-?[\d.]+)/.exec(await C(page, "c.hover"))[1]);
  assert.ok(Math.abs(sigmaHere - 0.5) < 0.01, `σ on the handle: ${sigmaHere}`);
  await screenshot(page, "cbf-fields-object");

  await page.keyboard.press("f");
  await page.waitForTimeout(300);
  const point = await C(
    page,
    "c.toScreen(c.fields().euclidean.points.positions)",
  );
  await page.mouse.move(point.x, point.y);
  await page.waitForFunction(
    () => /\): h [\d.]+/.test(window.distlab.cbf.hover ?? ""),
    null,
    { timeout: 10000 },
  );
  await screenshot(page, "cbf-fields");
  assert.deepEqual(page.problems, []);

  // The iso-levels typed in the panel: both runs' shells refetched at them (?levels=), named in
  // the legend and kept in the link.
  await page.click(".lil-gui .lil-title:has-text('Kelvin fields')");
  const levelsInput = page.locator('[data-testid="cbf-iso-levels"] input');
  const setLevels = async (text) => {
    await levelsInput.fill(text);
    await levelsInput.press("Enter");
  };
  const CHOSEN = [0.1, 0.3, 0.6];
  await setLevels("0.1, 0.3, 0.6");
  await page.waitForFunction(
    () =>
      Object.values(window.distlab.cbf.fields()).every(
        (w) => w.objects[0]?.shells.length === 3,
      ),
    null,
    { timeout: 60000 },
  );
  const chosen = await C(page, "c.fields()");
  for (const [key, w] of Object.entries(chosen)) {
    const o = w.objects[0];
    assert.deepEqual(
      o.shells.map((s) => s.level),
      CHOSEN,
      `${key}: the shells are at the chosen levels`,
    );
    assert.deepEqual(
      o.levels.map((l) => [l.level, l.empty]),
      CHOSEN.map((l) => [l, false]),
    );
    for (const s of o.shells)
      assert.ok(
        s.faces > 100 && s.visible && s.opacity < 1,
        `${key} shell h = ${s.level}: ${JSON.stringify(s)}`,
      );
  }
  assert.notEqual(
    chosen.euclidean.objects[0].shells[0].faces,
    chosen.euclidean.objects[0].shells[2].faces,
    "different levels, different shells",
  );
  const legendLines = async () =>
    page
      .locator('[data-testid="cbf-legend"] > div')
      .evaluateAll((d) => d.map((x) => x.textContent));
  const chosenLegend = await legendLines();
  for (const short of ["Eucl", "Eucl σ=0"])
    for (const l of CHOSEN)
      assert.ok(
        chosenLegend.some((t) => t.startsWith(`◯ ${short}: shell h = ${l} (`)),
        `legend names ${short}'s shell h = ${l}: ${chosenLegend.join(" | ")}`,
      );
  assert.ok(
    !chosenLegend.some((t) => /shell h = (0|0\.2) /.test(t)),
    "the default shells are gone from the legend",
  );
  assert.equal((await C(page, "c.state")).isoLevels, "0.1, 0.3, 0.6");
  await page.waitForFunction(
    () =>
      decodeURIComponent(location.hash).includes('"isoLevels":"0.1, 0.3, 0.6"'),
    null,
    { timeout: 10000 },
  );
  await screenshot(page, "cbf-fields-iso-levels");

  // What the server refuses (not numbers: 400; more than its max_levels: 413) is shown as an
  // error and the shells drawn stay, the panel back to their levels.
  for (const [bad, why] of [
    ["abc", /iso-levels "abc": levels must be finite numbers/],
    [
      Array.from({ length: 17 }, (_, i) => (i + 1) / 100).join(","),
      /iso-levels "[\d.,]+": levels: at most 16 levels \(max_levels\)/,
    ],
  ]) {
    await setLevels(bad);
    await page
      .locator("#toasts .toast-error", { hasText: why })
      .waitFor({ timeout: 30000 });
    assert.match(
      await page.locator("#status").textContent(),
      /^error: levels(:| must be)/,
    );
    const kept = await C(page, "c.fields()");
    for (const key of ["euclidean", "euclidean2"])
      assert.deepEqual(
        kept[key].objects[0].shells,
        chosen[key].objects[0].shells,
        `${key}: shells kept after "${bad}"`,
      );
    assert.equal((await C(page, "c.state")).isoLevels, "0.1, 0.3, 0.6");
    assert.equal(await levelsInput.inputValue(), "0.1, 0.3, 0.6");
    assert.deepEqual(await legendLines(), chosenLegend);
  }
  assert.deepEqual(
    page.problems.filter(
      (p) => !/the server responded with a status of (400|413)/.test(p),
    ),
    [],
  );
  await page.close();
});

test("the first run's progress names the field's preparation", async () => {
  // A field this server has not prepared (another l_x): its stages show in the progress bar.
  const page = await openWrench({ duration: 0.05 });
  await viewReady(page);
  const scenario = await page.evaluate(() =>
    window.distlab.api.get("/api/cbf/scenarios/wrench_grasp"),
  );
  scenario.fields[0].lx = 0.0024;
  await page.evaluate(() => {
    window.__labels = [];
    new MutationObserver(() =>
      window.__labels.push(document.getElementById("progress").textContent),
    ).observe(document.getElementById("progress"), {
      subtree: true,
      childList: true,
      characterData: true,
    });
  });
  await page.click(".lil-gui .lil-title:has-text('Scenario JSON')");
  await page.fill("[data-testid=cbf-editor]", JSON.stringify(scenario));
  await page.click("[data-testid=cbf-run-edited]");
  await page.waitForFunction(
    () => {
      const r = window.distlab.cbf.rollouts;
      return (
        r.length === 1 &&
        r[0].state === "finished" &&
        document.getElementById("progress").hidden
      );
    },
    null,
    { timeout: 600000, polling: 100 },
  );
  const labels = await page.evaluate(() => window.__labels.join("\n"));
  assert.match(
    labels,
    /preparing the Kelvin field “wrench” — (load|mesh|build|decomp|cache)/,
  );
  await page.waitForFunction(
    () => window.distlab.cbf.fields().euclidean?.objects.length === 1,
    null,
    { timeout: 60000 },
  );
  assert.deepEqual(page.problems, []);
  await page.close();
});

test("iso-levels in the link: the run's shells are drawn at them", async () => {
  const page = await openWrench({ duration: 0.05, isoLevels: "0,0.35" });
  await viewReady(page);
  await page.keyboard.press("r");
  await page.waitForFunction(
    () => window.distlab.cbf.fields().euclidean?.objects[0]?.shells.length,
    null,
    { timeout: 600000 },
  );
  const o = (await C(page, "c.fields()")).euclidean.objects[0];
  assert.deepEqual(
    o.shells.map((s) => s.level),
    [0, 0.35],
  );
  const legend = await page.locator('[data-testid="cbf-legend"]').textContent();
  assert.ok(legend.includes("Eucl: shell h = 0 (zero level set)"), legend);
  assert.ok(legend.includes("Eucl: shell h = 0.35 (iso-level)"), legend);
  assert.equal(
    await page.locator('[data-testid="cbf-iso-levels"] input').inputValue(),
    "0,0.35",
  );
  assert.deepEqual(page.problems, []);
  await page.close();
});
