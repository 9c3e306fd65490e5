// A parameter sweep from the CBF view (issue 14): the GAP obstacle margin over two values of the
// published corridor as one server job, its progress in the shell, then final distance to the
// target, smallest clearance and total variation plotted against the margin, the server's numbers.
import { test } from "node:test";
import assert from "node:assert/strict";
import { C, hash } from "./cbf_page.mjs";
import { openView, screenshot, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();

test("a margin sweep runs as one job and plots each run's outcome against the margin", async () => {
  const page = await openView(env.browser, env.server, hash({ scenario: "corridor", metric: "gap" }));
  await page.waitForFunction(() => window.distlab?.cbf && /press r/.test(document.getElementById("status")?.textContent ?? ""), null, { timeout: 60000 });
  await page.locator(".lil-title:text-is('Parameter sweep (one server job)')").click();
  const field = (name) => page.locator(`.lil-controller:has(.lil-name:text-is('${name}')) input`);
  assert.equal(await field("params key").inputValue(), "margins.gap.obstacle");
  await field("values").fill("0.002, 0.0002");
  await field("values").press("Enter");
  await page.locator(".lil-controller button:has-text('run sweep')").click();
  await page.waitForSelector("#progress:not([hidden])", { timeout: 30000 });
  await page.waitForFunction(() => window.distlab.cbf.sweep().plot !== null, null, { timeout: 120000, polling: 100 });
  const { sweep, plot } = await C(page, "c.sweep()");
  assert.equal(sweep.job.state, "succeeded");
  const server = await page.evaluate((id) => window.distlab.api.get(`/api/cbf/sweeps/${id}`), sweep.id);
  assert.deepEqual(server.values, [0.002, 0.0002]);
  assert.equal(server.entries.length, 2);
  // Plotted in increasing margin, the server's numbers (distances in cm).
  const byValue = [...server.entries].sort((a, b) => a.value - b.value);
  assert.deepEqual(plot.x, [0.0002, 0.002]);
  assert.deepEqual(plot.labels, ["final |p − p_d| (cm)", "min clearance (cm)", "Σ TV of u"]);
  assert.deepEqual(plot.y[0], byValue.map((e) => 100 * e.position_error));
  assert.deepEqual(plot.y[1], byValue.map((e) => 100 * e.min_clearance));
  assert.deepEqual(plot.y[2], byValue.map((e) => e.total_variation));
  // franka-corridor.md: the paper's margin stops ~16 cm short with converged D, 0.0002 within 2 cm.
  assert.ok(plot.y[0][1] > 10 && plot.y[0][0] <= 2, `final errors ${plot.y[0]}`);
  assert.match(await page.locator("#status").textContent(), /sweep succeeded: 2 of 2 runs of GAP exact over margins\.gap\.obstacle/);
  assert.deepEqual(page.problems, []);
  await screenshot(page, "cbf-sweep");
  await page.context().close();
});
