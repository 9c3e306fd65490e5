// The CBF rollouts view against the real server: a short rollout of both controllers streams in
// over the WebSocket and the timeline grows; scrubbing draws the server's poses of that step (the
// picture changes); both metrics' series are plotted and equal the record; the smoothness table
// shows the record's numbers; a shared URL re-runs and returns to its time; cancel stops the job
// midway; a bad inline scenario shows the server's message. Screenshots are kept as artifacts.
import { test } from "node:test";
import assert from "node:assert/strict";
import { canvasPixels, differentBytes, openView, screenshot, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();

const hash = (state) => `#/cbf?s=${encodeURIComponent(JSON.stringify(state))}`;
const C = (page, expr) => page.evaluate(`(() => { const c = window.distlab.cbf; return ${expr}; })()`);
const ended = (s) => s === "finished" || s === "cancelled" || s === "failed";

async function waitLoaded(page) {
  await page.waitForFunction(() => window.distlab?.cbf && /press r|finished|running|rollout/.test(document.getElementById("status")?.textContent ?? ""), null, { timeout: 30000 });
}

async function waitRunEnded(page, n, timeout = 120000) {
  await page.waitForFunction(
    (n) => {
      const r = window.distlab?.cbf?.rollouts; // undefined until the lazily loaded view mounts
      return !!r && r.length === n && r.every((x) => ["finished", "cancelled", "failed"].includes(x.state)) && document.getElementById("progress").hidden;
    },
    n,
    { timeout, polling: 50 },
  );
}

/** Poses [x, y, z, qw, qx, qy, qz] × n equal (float32 storage; a quaternion and its negative are one rotation). */
function samePoses(d, server, what) {
  assert.equal(d.length, server.length);
  for (let p = 0; p < d.length; p += 7) {
    const sign = Math.sign(d[p + 3] * server[p + 3] + d[p + 4] * server[p + 4] + d[p + 5] * server[p + 5] + d[p + 6] * server[p + 6]) || 1;
    for (let k = 0; k < 7; k++) {
      const w = k >= 3 ? sign * server[p + k] : server[p + k];
      assert.ok(Math.abs(d[p + k] - w) < 1e-5, `${what}: primitive ${p / 7} value ${k}: drawn ${d[p + k]}, server ${w}`);
    }
  }
}

const close = (a, b, tol) => Math.abs(a - b) <= tol * Math.max(1, Math.abs(b));

test("a short GAP-and-Euclidean rollout streams in, plays, scrubs and shows the record's numbers", async () => {
  const page = await openView(env.browser, env.server, hash({ duration: 2.5 }));
  await waitLoaded(page);
  assert.equal(await C(page, "c.length"), 0);
  await page.waitForTimeout(300);
  await screenshot(page, "cbf-at-q0");
  const q0Pixels = await canvasPixels(page);
  const atQ0 = (await C(page, "c.drawn()")).gap; // the page's own forward kinematics of /api/cbf/robot
  assert.equal(atQ0.step, -1);

  // Watch the timeline's length while the rollouts run (sampled in the page every 5 ms).
  await page.evaluate(() => {
    window.__lengths = [];
    window.__sampler = setInterval(() => window.__lengths.push(window.distlab.cbf.length), 5);
  });
  await page.keyboard.press("r");
  await page.waitForSelector("#progress:not([hidden])", { timeout: 10000 });
  await waitRunEnded(page, 2);
  const lengths = await page.evaluate(() => (clearInterval(window.__sampler), window.__lengths));
  const rollouts = await C(page, "c.rollouts");
  assert.deepEqual(rollouts.map((r) => [r.metric, r.state, r.stepsDone, r.contiguous]), [["gap", "finished", 250, 250], ["euclidean", "finished", 250, 250]]);
  const distinct = [...new Set(lengths)].filter((n) => n > 0 && n < 250);
  assert.ok(distinct.length >= 2, `the timeline grew while frames came in (lengths seen: ${[...new Set(lengths)].join(", ")})`);
  for (const r of rollouts) assert.ok(r.wsMessages >= 2, `${r.metric}: frames came over the WebSocket in several messages (${r.wsMessages}; ${r.restPages} pages fetched)`);
  assert.equal(await C(page, "c.length"), 250);
  assert.equal(await C(page, "c.step"), 249, "the playhead followed the live frames to the end");
  await page.waitForTimeout(300);
  await screenshot(page, "cbf-streamed");

  // Both metrics' series in the velocity plot, equal to the records' u.
  const plots = await C(page, "c.plots()");
  const rec = { gap: await C(page, 'c.record("gap")'), euclidean: await C(page, 'c.record("euclidean")') };
  for (const [m, short] of [["gap", "GAP"], ["euclidean", "Eucl"]]) {
    for (let j = 0; j < 7; j++) {
      const k = plots.velocity.labels.indexOf(`u${j + 1} ${short}`);
      assert.ok(k >= 0, `series u${j + 1} ${short} is plotted`);
      const y = plots.velocity.y[k];
      assert.equal(y.length, 250);
      y.forEach((v, i) => assert.equal(v, rec[m].u[i][j], `${m} u${j + 1} at step ${i}`));
    }
    const err = plots.error.y[plots.error.labels.indexOf(`‖r‖ ${short}`)];
    err.forEach((v, i) => assert.equal(v, rec[m].task_error[i]));
    const clearance = plots.distance.y[plots.distance.labels.indexOf(`clearance ${short}`)];
    clearance.forEach((v, i) => assert.equal(v, rec[m].min_distance[i]));
  }
  // The Euclidean controller's velocities are visibly rougher (paper Fig. 4): not a number we assert, just shown.

  // The smoothness table shows exactly the records' numbers.
  const table = await C(page, "c.table()");
  assert.equal(table.length, 7 * 2 * 2);
  for (const cell of table) {
    const want = rec[cell.metric].smoothness[cell.key][cell.joint];
    assert.equal(cell.value, want, `${cell.metric} ${cell.key} joint ${cell.joint + 1}`);
    assert.ok(close(Number(cell.text), want, 1e-3), `shown "${cell.text}" rounds ${want}`);
  }
  const timing = await page.locator("[data-testid=cbf-timing] tr:has-text('whole step') td").allTextContents();
  assert.equal(Number(timing[1]), Number(rec.gap.timing.step_us_mean.toFixed(1)));
  assert.equal(Number(timing[2]), Number(rec.euclidean.timing.step_us_mean.toFixed(1)));

  // Scrubbing: the slider moves the playhead, and the drawn robot is the server's pose of that step.
  const poseAt = async (metric, i) =>
    page.evaluate(
      async ({ id, i }) => (await window.distlab.api.get(`/api/cbf/rollouts/${id}/frames?from=${i}&count=1`)).frames[0].poses.flat(),
      { id: rollouts.find((r) => r.metric === metric).id, i },
    );
  // The robot drawn at q0 before the run (page-side kinematics) is the server's pose of step 0.
  samePoses(atQ0.poses, await poseAt("gap", 0), "q0");
  await page.keyboard.press("Home");
  assert.equal(await C(page, "c.step"), 0);
  await page.waitForTimeout(200);
  const pixelsStart = await canvasPixels(page);
  assert.ok(differentBytes(q0Pixels, pixelsStart) > 0, "witness segments appear at step 0");
  // A real mouse drag along the slider, from its start to 80 % of its length.
  const box = await page.locator("[data-testid=cbf-slider]").boundingBox();
  await page.mouse.move(box.x + 6, box.y + box.height / 2);
  await page.mouse.down();
  for (let i = 1; i <= 10; i++) await page.mouse.move(box.x + 6 + (box.width * 0.8 - 6) * (i / 10), box.y + box.height / 2);
  await page.mouse.up();
  const scrubbed = await C(page, "c.step");
  assert.ok(scrubbed > 150 && scrubbed < 230, `the drag scrubbed to ~80 % (step ${scrubbed})`);
  assert.equal(await C(page, "c.playing"), false);
  const drawn = await C(page, "c.drawn()");
  for (const m of ["gap", "euclidean"]) {
    assert.equal(drawn[m].step, scrubbed);
    const server = await poseAt(m, scrubbed);
    samePoses(drawn[m].poses, server, `${m} at step ${scrubbed}`);
    // The witnesses drawn are those of the 4 pairs with the smallest controller distance D.
    const frame = await page.evaluate(
      async ({ id, i }) => (await window.distlab.api.get(`/api/cbf/rollouts/${id}/frames?from=${i}&count=1`)).frames[0],
      { id: rollouts.find((r) => r.metric === m).id, i: scrubbed },
    );
    const closest = frame.distance.map((d, k) => [d, k]).sort((a, b) => a[0] - b[0]).slice(0, 4).map(([, k]) => k);
    assert.deepEqual(drawn[m].witnesses, closest, `${m}: the 4 closest pairs' witnesses are drawn`);
  }
  await page.waitForTimeout(200);
  const pixelsScrubbed = await canvasPixels(page);
  assert.ok(differentBytes(pixelsStart, pixelsScrubbed) > 1000, "the robots moved on the canvas");
  await screenshot(page, "cbf-scrubbed-t2");

  // A click in a plot seeks to that time.
  const over = await page.locator("#bottom .plot .u-over").first().boundingBox();
  await page.mouse.click(over.x + over.width * 0.5, over.y + over.height / 2);
  const picked = await C(page, "c.step");
  assert.ok(Math.abs(picked - 125) <= 3, `clicking the middle of the velocity plot seeks to ~1.25 s (step ${picked})`);
  await page.locator("[data-testid=cbf-slider]").focus();
  await page.keyboard.press("End"); // the slider's own key handling
  await page.locator("[data-testid=cbf-slider]").blur();
  const scrubbedEnd = await C(page, "c.step");
  assert.equal(scrubbedEnd, 249);
  await page.keyboard.press("ArrowLeft"); // the view's shortcut (the slider has no focus now)
  assert.equal(await C(page, "c.step"), 248);

  // Keys: → steps, Space plays (and the frame rate while playing is measured), Space pauses.
  await page.keyboard.press("ArrowRight");
  assert.equal(await C(page, "c.step"), 249);
  await page.keyboard.press("Home");
  await C(page, "c.resetFrameStats()");
  await page.keyboard.press(" ");
  assert.equal(await C(page, "c.playing"), true);
  await page.waitForTimeout(1500);
  const stats = await C(page, "c.frameStats()");
  await page.keyboard.press(" ");
  assert.equal(await C(page, "c.playing"), false);
  const played = await C(page, "c.step");
  assert.ok(played > 20, `playback advanced (${played} steps in 1.5 s at 1×)`);
  const lat = (await C(page, "c.timings()")).arrivalToDrawnMs.sort((a, b) => a - b);
  console.log(
    `# playing: median frame interval ${stats.medianMs.toFixed(1)} ms (p95 ${stats.p95Ms.toFixed(1)}) over ${stats.frames} frames; ` +
      `frame arrival → drawn: median ${lat[Math.floor(lat.length / 2)]?.toFixed(1)} ms, p95 ${lat[Math.floor(lat.length * 0.95)]?.toFixed(1)} ms (${lat.length} batches)`,
  );

  // Side by side, then a shared URL: re-runs both rollouts and returns to the same time.
  await page.keyboard.press("l");
  await page.keyboard.press("End");
  await page.waitForTimeout(400);
  await screenshot(page, "cbf-side-by-side");
  await page.keyboard.press("Home");
  await page.keyboard.press("PageUp"); // + 1 s = 100 steps
  for (let i = 0; i < 23; i++) await page.keyboard.press("ArrowRight");
  assert.equal(await C(page, "c.step"), 123);
  await page.waitForTimeout(400); // the URL is written debounced
  const shared = await page.evaluate(() => location.hash);
  assert.match(decodeURIComponent(shared), /"run":true/);
  const again = await openView(env.browser, env.server, shared);
  await waitRunEnded(again, 2);
  assert.equal(await C(again, "c.step"), 123);
  assert.equal((await C(again, "c.state")).layout, "side");
  const recAgain = await C(again, 'c.record("gap")');
  assert.deepEqual(recAgain.u, rec.gap.u, "the re-run computes the same rollout");
  assert.deepEqual(page.problems, []);
  assert.deepEqual(again.problems, []);
});

test("cancel stops a long rollout midway; what was computed stays playable", async () => {
  const page = await openView(env.browser, env.server, hash({ duration: 60, metric: "gap" }));
  await waitLoaded(page);
  await page.keyboard.press("r");
  await page.waitForFunction(() => window.distlab?.cbf?.length > 0, null, { timeout: 30000, polling: 20 });
  await page.click("#progress-cancel");
  await waitRunEnded(page, 1, 60000);
  const [r] = await C(page, "c.rollouts");
  assert.equal(r.state, "cancelled");
  assert.ok(r.stepsDone > 0 && r.stepsDone < r.stepsTotal, `stopped midway: ${r.stepsDone} of ${r.stepsTotal}`);
  const job = await page.evaluate((id) => window.distlab.api.get(`/api/jobs/${id}`), r.id);
  assert.equal(job.state, "cancelled");
  await page.waitForTimeout(500);
  assert.equal(await C(page, "c.length"), r.stepsDone, "no frames after the end, and every computed step is playable");
  const rec = await C(page, 'c.record("gap")');
  assert.equal(rec.summary.cancelled, true);
  assert.equal(rec.steps, r.stepsDone);
  assert.match(await page.textContent("[data-testid=cbf-summary]"), /cancelled after \d+ of 6000 steps/);
  await screenshot(page, "cbf-cancelled");

  // Leaving the view while a rollout runs cancels its job (the view stops what it started).
  await page.keyboard.press("r");
  await page.waitForFunction(() => window.distlab.cbf.rollouts[0]?.id && window.distlab.cbf.rollouts[0].state === "running" && window.distlab?.cbf?.length > 0, null, { timeout: 30000, polling: 20 });
  const running = (await C(page, "c.rollouts"))[0];
  await page.evaluate(() => (location.hash = "#/gap"));
  await page.waitForFunction(
    async (id) => ["cancelled", "succeeded"].includes((await window.distlab.api.get(`/api/jobs/${id}`)).state),
    running.id,
    { timeout: 30000, polling: 200 },
  );
  const left = await page.evaluate((id) => window.distlab.api.get(`/api/jobs/${id}`), running.id);
  assert.equal(left.state, "cancelled");
  assert.equal(await page.evaluate(() => window.distlab.cbf), undefined, "the hooks went with the view");
  assert.deepEqual(page.problems, []);
});

test("a bad inline scenario shows the server's message and field", async () => {
  const page = await openView(env.browser, env.server, hash({ duration: 1 }));
  await waitLoaded(page);
  const scenario = await page.evaluate(() => window.distlab.api.get("/api/cbf/scenarios/corridor"));
  scenario.obstacles[1].shape.size[2] = -0.9;
  const session = (await (await fetch(env.server.url + "api/session", { method: "POST" })).json()).session;
  const direct = await fetch(env.server.url + "api/cbf/rollouts", {
    method: "POST",
    headers: { "X-Distlab-Session": session, "Content-Type": "application/json" },
    body: JSON.stringify({ scenario, metric: "gap", params: { duration: 1 } }),
  });
  assert.equal(direct.status, 400);
  const expected = (await direct.json()).error;
  assert.equal(expected.field, "scenario.obstacles[1].shape.size[2]");

  await page.click(".lil-gui .lil-title:has-text('Scenario JSON')");
  await page.fill("[data-testid=cbf-editor]", JSON.stringify(scenario, null, 1));
  await page.click("[data-testid=cbf-run-edited]");
  await page.waitForFunction(() => /✗/.test(document.querySelector("[data-testid=cbf-verdict]")?.textContent ?? ""), null, { timeout: 30000 });
  const verdict = await page.textContent("[data-testid=cbf-verdict]");
  assert.ok(verdict.includes(expected.field) && verdict.includes(expected.message), `verdict "${verdict}" names ${expected.field}: ${expected.message}`);
  assert.ok(!verdict.includes(`${expected.field}: ${expected.field}`), `verdict "${verdict}" repeats the field`);
  const toast = await page.locator(".toast-error").last().textContent();
  assert.ok(toast.includes(expected.message));
  await screenshot(page, "cbf-bad-scenario");

  // Not JSON at all: said locally, nothing sent.
  await page.fill("[data-testid=cbf-editor]", "{ obstacles: oops");
  await page.click("[data-testid=cbf-run-edited]");
  assert.match(await page.textContent("[data-testid=cbf-verdict]"), /not valid JSON/);
  assert.deepEqual(page.problems.filter((p) => !p.includes("the server responded with a status of 400")), []);
});

test("the duration is the scenario's own unless set; after a run the status line says why the arm stopped", async () => {
  const page = await openView(env.browser, env.server, hash({ scenario: "corridor_real", metric: "euclidean" }));
  await waitLoaded(page);
  assert.equal((await C(page, "c.state")).duration, null, "no duration in the link: the scenario's own");
  const shown = await page.evaluate(() => {
    const row = [...document.querySelectorAll(".lil-controller")].find((c) => c.textContent.includes("duration (s)"));
    return row?.querySelector("input")?.value;
  });
  assert.equal(Number(shown), 20, "the panel shows corridor_real's 20 s");

  const short = await openView(env.browser, env.server, hash({ scenario: "corridor", metric: "euclidean", duration: 0.5 }));
  await waitLoaded(short);
  await short.keyboard.press("r");
  await waitRunEnded(short, 1);
  // The rollout's own line, then the exact target's feasibility (POST /api/cbf/feasibility).
  await short.waitForFunction(() => /exact target: best clearance/.test(document.getElementById("status")?.textContent ?? ""), null, {
    timeout: 60000,
  });
  const status = await short.evaluate(() => document.getElementById("status").textContent);
  assert.match(status, /Eucl\S* finished: stopped \d+\.\d+ cm from the target/);
  assert.match(status, /exact target: best clearance 2\.65 cm \(link5_cylinder\/wall1\) < Euclidean δ 3\.00 cm/);
  await screenshot(short, "cbf-status-line");
});

test("the GAP distance switch runs the published package's iteration (gap.mode as_published in the record)", async () => {
  const page = await openView(env.browser, env.server, hash({ scenario: "corridor", metric: "gap", gapMode: "as_published_real", duration: 0.3 }));
  await waitLoaded(page);
  await page.keyboard.press("r");
  await waitRunEnded(page, 1);
  const [r] = await C(page, "c.rollouts");
  assert.equal(r.state, "finished");
  const record = await page.evaluate((id) => window.distlab.api.get(`/api/cbf/rollouts/${id}/record`), r.id);
  assert.equal(record.gap_mode, "as_published");
  assert.equal(record.steps, 30);
});
