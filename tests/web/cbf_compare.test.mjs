// Two rollouts overlaid on the same plots and robot (issue 17 item 13): the GAP rollout with the
// converged distance and the same scenario as the published package computed it (gap.mode
// as_published), or Euclidean against a GAP mode; both drawn in their own colours, the plots'
// legends, the readout and the legend over the view naming each, every series equal to its record.
import { test } from "node:test";
import assert from "node:assert/strict";
import { C, hash, runEnded } from "./cbf_page.mjs";
import { openView, screenshot, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();

/** Poses equal within float32 storage (a quaternion and its negative are one rotation). */
function samePoses(d, server, what) {
  assert.equal(d.length, server.length);
  for (let p = 0; p < d.length; p += 7) {
    const dot = [3, 4, 5, 6].reduce((s, k) => s + d[p + k] * server[p + k], 0);
    for (let k = 0; k < 3; k++) assert.ok(Math.abs(d[p + k] - server[p + k]) < 1e-5, `${what}: primitive ${p / 7} position ${k}`);
    assert.ok(Math.abs(Math.abs(dot) - 1) < 1e-5, `${what}: primitive ${p / 7} rotation`);
  }
}

test("GAP exact and GAP as published overlaid: both computed, drawn, plotted and named", async () => {
  const page = await openView(env.browser, env.server, hash({ scenario: "corridor", metric: "gap", compare: "gap_as_published_real", duration: 0.5 }));
  await page.waitForFunction(() => window.distlab?.cbf && /press r/.test(document.getElementById("status")?.textContent ?? ""), null, { timeout: 60000 });
  await page.keyboard.press("r");
  await runEnded(page, 2);
  const rollouts = await C(page, "c.rollouts");
  assert.deepEqual(rollouts.map((r) => [r.key, r.label, r.state]), [["gap", "GAP exact", "finished"], ["gap2", "GAP as published (5e-4 / 20)", "finished"]]);
  // Each rollout computed what its name says (the server's record states its GAP mode).
  const rec = {};
  for (const r of rollouts) rec[r.key] = await page.evaluate((id) => window.distlab.api.get(`/api/cbf/rollouts/${id}/record`), r.id);
  assert.equal(rec.gap.gap_mode, "exact");
  assert.equal(rec.gap2.gap_mode, "as_published");
  assert.deepEqual(await C(page, 'c.record("gap2")'), rec.gap2);
  // The two differ (else the overlay would show nothing): the published iteration's D is not the converged one.
  assert.notDeepEqual(rec.gap.u, rec.gap2.u);

  // Same plots: every series of both rollouts, named by their legends, equal to the records.
  const plots = await C(page, "c.plots()");
  for (const [key, short] of [["gap", "GAP"], ["gap2", "GAP pub 5e-4/20"]]) {
    for (let j = 0; j < 7; j++) {
      const k = plots.velocity.labels.indexOf(`u${j + 1} ${short}`);
      assert.ok(k >= 0, `series u${j + 1} ${short} is plotted`);
      plots.velocity.y[k].forEach((v, i) => assert.equal(v, rec[key].u[i][j], `${key} u${j + 1} at step ${i}`));
    }
    const err = plots.error.y[plots.error.labels.indexOf(`‖r‖ ${short}`)];
    err.forEach((v, i) => assert.equal(v, rec[key].task_error[i]));
    const clearance = plots.distance.y[plots.distance.labels.indexOf(`clearance ${short}`)];
    clearance.forEach((v, i) => assert.equal(v, rec[key].min_distance[i]));
  }
  const title = await page.locator("#bottom .u-title").first().textContent();
  assert.match(title, /GAP exact solid, GAP as published \(5e-4 \/ 20\) dashed/);

  // Same robot view: two arms, in different colours, each at its own rollout's pose of the step drawn.
  await page.keyboard.press("Home");
  await page.keyboard.press("PageUp"); // 1 s forward: clamped to the last step, 49
  const drawn = await C(page, "c.drawn()");
  assert.deepEqual(Object.keys(drawn).sort(), ["gap", "gap2"]);
  assert.ok(drawn.gap.visible && drawn.gap2.visible);
  assert.notEqual(drawn.gap.color, drawn.gap2.color);
  for (const r of rollouts) {
    const step = drawn[r.key].step;
    assert.equal(step, 49);
    const server = await page.evaluate(async ({ id, step }) => (await window.distlab.api.get(`/api/cbf/rollouts/${id}/frames?from=${step}&count=1`)).frames[0].poses.flat(), { id: r.id, step });
    samePoses(drawn[r.key].poses, server, `${r.key} at step ${step}`);
  }
  const legend = await page.locator("[data-testid=cbf-legend]").textContent();
  assert.match(legend, /GAP exact controller/);
  assert.match(legend, /GAP as published \(5e-4 \/ 20\) controller/);
  const readout = (await page.locator("[data-testid=cbf-readout]").textContent()).split("\n");
  assert.equal(readout.length, 2);
  assert.match(readout[0], /^GAP exact +t 0\.49 s/);
  assert.match(readout[1], /^GAP as published \(5e-4 \/ 20\) +t 0\.49 s/);
  // The numbers of both, side by side.
  const table = await C(page, "c.table()");
  assert.deepEqual([...new Set(table.map((c) => c.metric))], ["gap", "gap2"]);
  for (const cell of table) assert.equal(cell.value, rec[cell.metric].smoothness[cell.key][cell.joint]);
  assert.deepEqual(page.problems, []);
  await screenshot(page, "cbf-compare-exact-published");
  await page.context().close();
});

test("Euclidean compared with GAP as published, chosen in the panel; the choice is in the link", async () => {
  const page = await openView(env.browser, env.server, hash({ scenario: "corridor", metric: "euclidean", duration: 0.2 }));
  await page.waitForFunction(() => window.distlab?.cbf && /press r/.test(document.getElementById("status")?.textContent ?? ""), null, { timeout: 60000 });
  assert.deepEqual((await C(page, "c.shown")).map((s) => s.key), ["euclidean"]);
  const select = page.locator(".lil-controller:has(.lil-name:text-is('compare with')) select");
  await select.selectOption({ label: "GAP as published, 2e-4 / 300" });
  assert.deepEqual((await C(page, "c.shown")).map((s) => s.label), ["Euclidean", "GAP as published (2e-4 / 300)"]);
  assert.equal((await C(page, "c.state")).compare, "gap_as_published_sim");
  // The link is written debounced (150 ms after the last change): wait for it, then check it.
  await page.waitForFunction(() => decodeURIComponent(location.hash).includes('"compare"'), null, { timeout: 5000 }).catch(() => {});
  assert.match(decodeURIComponent(await page.evaluate(() => location.hash)), /"compare":"gap_as_published_sim"/);
  await page.keyboard.press("r");
  await runEnded(page, 2);
  const rollouts = await C(page, "c.rollouts");
  assert.deepEqual(rollouts.map((r) => [r.key, r.metric, r.state]), [["euclidean", "euclidean", "finished"], ["gap", "gap", "finished"]]);
  const rec = await page.evaluate((id) => window.distlab.api.get(`/api/cbf/rollouts/${id}/record`), rollouts[1].id);
  assert.equal(rec.gap_mode, "as_published");
  const labels = (await C(page, "c.plots()")).velocity.labels;
  assert.deepEqual(labels.slice(0, 2), ["u1 Eucl", "u1 GAP pub 2e-4/300"]);
  assert.deepEqual(page.problems, []);
  await page.context().close();
});
