// The CBF view's pair chart (issue 32): for the selected step, one bar per pair of each rollout
// (GAP and Euclidean side by side), equal to the server's frame of that step, and the margin line
// over each pair at δ obstacle or δ self of the rollout's metric, as the rollout's status gives
// them; stepping the timeline moves the bars to the new step's distances.
import { test } from "node:test";
import assert from "node:assert/strict";
import { C, hash, runEnded } from "./cbf_page.mjs";
import { openView, screenshot, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();

test("the pair chart shows one bar per pair and the margin line at the selected step", async () => {
  const page = await openView(env.browser, env.server, hash({ duration: 0.3 }));
  await page.waitForFunction(() => window.distlab?.cbf && /press r/.test(document.getElementById("status")?.textContent ?? ""), null, { timeout: 60000 });
  await page.keyboard.press("r");
  await runEnded(page, 2);
  const rollouts = await C(page, "c.rollouts");
  assert.deepEqual(
    rollouts.map((r) => [r.metric, r.state]),
    [
      ["gap", "finished"],
      ["euclidean", "finished"],
    ],
  );
  const status = {};
  for (const r of rollouts) status[r.metric] = await page.evaluate((id) => window.distlab.api.get(`/api/cbf/rollouts/${id}`), r.id);
  const n = status.gap.pairs.length;
  assert.ok(n > 1, `the corridor has several pairs (${n})`);
  assert.deepEqual(
    status.euclidean.pairs.map((p) => p.name),
    status.gap.pairs.map((p) => p.name),
  );
  assert.notEqual(status.gap.margins.obstacle, status.euclidean.margins.obstacle, "each metric has its own margin");

  // Step k of the timeline (Home, then k steps forward): the chart against the server's frame k.
  const check = async (k) => {
    await page.keyboard.press("Home");
    for (let i = 0; i < k; i++) await page.keyboard.press("ArrowRight");
    assert.equal(await C(page, "c.step"), k);
    const chart = await page.waitForFunction(
      (k) => {
        const p = window.distlab.cbf.plots().pairs;
        return p && window.distlab.plots().some((d) => d.title === `pair distances at t = ${(k * 0.01).toFixed(2)} s`) ? p : null;
      },
      k,
      { timeout: 30000 },
    );
    const p = await chart.jsonValue();
    assert.deepEqual(p.labels, ["D GAP", "δ GAP", "D Eucl", "δ Eucl"]);
    assert.deepEqual(
      p.x,
      Array.from({ length: n }, (_, i) => i),
    );
    for (const [s, metric] of [
      [0, "gap"],
      [2, "euclidean"],
    ]) {
      const r = rollouts.find((x) => x.metric === metric);
      const frame = (await page.evaluate(({ id, k }) => window.distlab.api.get(`/api/cbf/rollouts/${id}/frames?from=${k}&count=1`), { id: r.id, k })).frames[0];
      assert.equal(frame.i, k);
      assert.equal(frame.distance.length, n);
      const bars = p.y[s];
      const margin = p.y[s + 1];
      for (let i = 0; i < n; i++) {
        const d = frame.distance[i];
        if (d > 0) assert.equal(bars[i], d, `${metric} pair ${status[metric].pairs[i].name} at step ${k}`);
        else assert.equal(bars[i], null, `${metric} pair ${i} overlaps: no bar`);
        const m = status[metric].pairs[i].self ? status[metric].margins.self : status[metric].margins.obstacle;
        assert.equal(margin[i], m, `${metric} pair ${i}: its margin`);
      }
      // Drawn: one bar per pair with a distance, one margin segment per pair.
      assert.equal(p.drawn[s], bars.filter((v) => v !== null).length, `${metric}: bars drawn`);
      assert.equal(p.drawn[s], n, `${metric}: one bar per pair (none overlaps here)`);
      assert.equal(p.drawn[s + 1], n, `${metric}: the margin line over every pair`);
    }
    return p;
  };
  const first = await check(0);
  const later = await check(20);
  assert.notDeepEqual(later.y[0], first.y[0], "the bars follow the step");

  // The figure on the page: titled with its time, axes with units, a legend naming each series.
  const figure = (await page.evaluate(() => window.distlab.plots())).find((d) => d.title.startsWith("pair distances"));
  assert.equal(figure.axes[0].label, "pair (#)");
  assert.equal(figure.axes[1].label, "D (m)");
  assert.ok(
    figure.axes.every((a) => a.ticks.length >= 2),
    JSON.stringify(figure.axes),
  );
  assert.deepEqual(figure.legend.slice(-4), ["D GAP", "δ GAP", "D Eucl", "δ Eucl"]);
  assert.ok(await page.locator("[data-testid=cbf-pair-bars]").isVisible());
  await screenshot(page, "cbf-pair-bars");
  assert.deepEqual(page.problems, []);
  await page.context().close();
});
