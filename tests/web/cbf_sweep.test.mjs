// A parameter sweep from the CBF view (issue 14): the GAP obstacle margin over two values of the
// published corridor as one server job, its progress in the shell, then final distance to the
// target, smallest clearance and total variation plotted against the margin, the server's numbers.
// Issue 37: values spanning more than a decade on a log axis; a refused sweep marks the previous
// sweep's plot stale, and its error toast goes with the next sweep that runs.
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

/** The CBF view with one second of the corridor per run, its sweep folder open; field(name) is a
 *  sweep field's input, run() presses "run sweep". */
async function sweepPage() {
  const page = await openView(env.browser, env.server, hash({ scenario: "corridor", metric: "gap", duration: 1 }));
  await page.waitForFunction(() => window.distlab?.cbf && /press r/.test(document.getElementById("status")?.textContent ?? ""), null, { timeout: 60000 });
  await page.locator(".lil-title:text-is('Parameter sweep (one server job)')").click();
  const field = (name) => page.locator(`.lil-controller:has(.lil-name:text-is('${name}')) input`);
  const run = () => page.locator(".lil-controller button:has-text('run sweep')").click();
  const set = async (name, text) => {
    await field(name).fill(text);
    await field(name).press("Enter");
  };
  return { page, field, run, set };
}

test("a sweep over more than a decade is drawn on a log axis, one within a decade on a linear one", async () => {
  const { page, field, run, set } = await sweepPage();
  // The panel's default: 2e-3, 5e-4, 2e-4, 1e-4 (a factor of 20).
  assert.equal(await field("values").inputValue(), "0.002, 0.0005, 0.0002, 0.0001");
  await run();
  await page.waitForFunction(() => window.distlab.cbf.sweep().plot !== null, null, { timeout: 120000, polling: 100 });
  let { plot } = await C(page, "c.sweep()");
  assert.deepEqual(plot.x, [0.0001, 0.0002, 0.0005, 0.002]);
  // Tick labels at 1e-4 and 1e-3 (a linear axis would label 5e-4, 1e-3, … and crowd three runs
  // into its first quarter).
  const figure = (await page.evaluate(() => window.distlab.plots())).find((p) => /^sweep of/.test(p.title));
  const ticks = figure.axes[0].ticks.map(Number);
  assert.ok(ticks.length >= 2 && Math.min(...ticks) <= 1e-4 && Math.max(...ticks) >= 1e-3, `ticks across both decades: ${figure.axes[0].ticks}`);
  assert.equal(plot.xDistr, 3, "the parameter's axis is logarithmic");
  assert.match(figure.axes[0].label, /margins\.gap\.obstacle \(log axis\)/);
  await screenshot(page, "cbf-sweep-log-axis");
  // A factor of 2: linear.
  await set("values", "0.002, 0.001");
  await run();
  await page.waitForFunction(() => window.distlab.cbf.sweep().plot?.x.length === 2, null, { timeout: 120000, polling: 100 });
  ({ plot } = await C(page, "c.sweep()"));
  assert.equal(plot.xDistr, 1);
  assert.deepEqual(page.problems, []);
  await page.context().close();
});

test("a refused sweep marks the previous sweep's plot stale; the refusal's toast goes with the next sweep that runs", async () => {
  const { page, run, set } = await sweepPage();
  await set("values", "0.002, 0.001");
  await run();
  await page.waitForFunction(() => window.distlab.cbf.sweep().plot?.x.length === 2, null, { timeout: 120000, polling: 100 });
  assert.equal((await C(page, "c.sweep()")).plot.stale ?? null, null);
  // A key the server does not know: refused (400). The curves shown are the previous sweep's.
  await set("params key", "margins.gap.nonsense");
  await run();
  await page.locator(".toast-error", { hasText: "sweep" }).waitFor({ timeout: 30000 });
  await page.waitForFunction(() => document.getElementById("progress")?.hidden !== false);
  const { plot } = await C(page, "c.sweep()");
  assert.ok(plot?.stale, "the previous sweep's plot is marked stale after the refusal");
  assert.match(plot.stale, /margins\.gap\.nonsense/);
  const mark = page.locator("[data-testid=cbf-sweep-plot] .plot-stale");
  assert.ok(await mark.isVisible());
  assert.match(await mark.textContent(), /not updated — the sweep of margins\.gap\.nonsense failed: .*previous sweep/);
  await screenshot(page, "cbf-sweep-stale");
  // Values not numbers: not sent, the plot stays marked.
  await set("params key", "margins.gap.obstacle");
  await set("values", "0.002, abc");
  await run();
  await page.locator(".toast-error", { hasText: "numbers separated by commas" }).waitFor();
  assert.match((await C(page, "c.sweep()")).plot.stale, /not numbers/);
  // Fixed: the sweep runs, its plot is current and the toasts about the sweep are gone.
  await set("values", "0.002, 0.0015");
  await run();
  await page.waitForFunction(() => window.distlab.cbf.sweep().plot?.x[0] === 0.0015 && !window.distlab.cbf.sweep().plot.stale, null, { timeout: 120000, polling: 100 });
  assert.equal(await page.locator(".toast-error", { hasText: "sweep" }).count(), 0, "the sweep's error toasts went with the sweep that ran");
  const other = page.problems.filter((p) => !/status of 400/.test(p));
  assert.deepEqual(other, []);
  await page.context().close();
});
