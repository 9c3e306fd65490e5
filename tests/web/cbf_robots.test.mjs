// The CBF view and robots as data: a scenario of another robot (ur5e_reach, assets/robots/ur5e.urdf)
// draws that robot from its URDF joints at q0, the same poses the server streams for step 0; and a
// finished rollout's record downloads as JSON (the server's record) and CSV (its per-step series);
// the plots, readout, joint list and shortcuts follow the robot's own joints (six for the UR5e).
import { test } from "node:test";
import assert from "node:assert/strict";
import { readFileSync } from "node:fs";
import { C, hash, runEnded } from "./cbf_page.mjs";
import { openView, screenshot, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();

test("a UR5e scenario draws the UR5e from its URDF, as the server poses it", async () => {
  const page = await openView(env.browser, env.server, hash({ scenario: "ur5e_reach", duration: 0.2, metric: "gap" }));
  await page.waitForFunction(() => window.distlab?.cbf && /press r/.test(document.getElementById("status")?.textContent ?? ""), null, { timeout: 60000 });
  const atQ0 = (await C(page, "c.drawn()")).gap;
  assert.equal(atQ0.poses.length, 6 * 7, "six primitives of the UR5e drawn (not the Panda's nine)");
  await page.keyboard.press("r");
  await runEnded(page, 1);
  const id = (await C(page, "c.rollouts"))[0].id;
  const server = await page.evaluate(async (id) => (await window.distlab.api.get(`/api/cbf/rollouts/${id}/frames?from=0&count=1`)).frames[0].poses.flat(), id);
  assert.equal(server.length, atQ0.poses.length);
  for (let p = 0; p < server.length; p += 7) {
    for (let k = 0; k < 3; k++) assert.ok(Math.abs(atQ0.poses[p + k] - server[p + k]) < 1e-5, `primitive ${p / 7} position ${k}`);
    const dot = [3, 4, 5, 6].reduce((s, k) => s + atQ0.poses[p + k] * server[p + k], 0);
    assert.ok(Math.abs(Math.abs(dot) - 1) < 1e-5, `primitive ${p / 7} rotation`);
  }
  await screenshot(page, "cbf-ur5e");
  await page.context().close();
});

test("the UR5e scenario plays with its six joints: plots, readout, joint list and j follow the robot", async () => {
  const page = await openView(env.browser, env.server, hash({ scenario: "ur5e_reach", duration: 0.3, metric: "gap", joint: 7 }));
  await page.waitForFunction(() => window.distlab?.cbf?.drawn().gap?.poses.length === 6 * 7 && /press r/.test(document.getElementById("status")?.textContent ?? ""), null, { timeout: 60000 });
  const server = await page.evaluate(() => window.distlab.api.get("/api/cbf/robot?name=ur5e"));
  assert.equal(server.joint_names.length, 6);
  // The joint list: "all" and the robot's six joints by name.
  const options = await page.locator(".lil-controller:has(.lil-name:text-is('plot joints (j)')) option").allTextContents();
  assert.deepEqual(options, ["all", ...server.joint_names.map((n, j) => `${j + 1} (${n})`)]);
  assert.equal((await C(page, "c.state")).joint, 0, "joint 7 does not exist on this robot: all joints plotted");
  const robot = await C(page, "c.robot");
  assert.equal(robot.dof, 6);
  assert.deepEqual(robot.joint_names, server.joint_names);

  await page.keyboard.press("r");
  await runEnded(page, 1);
  const rec = await C(page, 'c.record("gap")');
  assert.equal(rec.u[0].length, 6);
  const plots = await C(page, "c.plots()");
  assert.deepEqual(plots.velocity.labels, [1, 2, 3, 4, 5, 6].map((j) => `u${j} GAP`));
  plots.velocity.y.forEach((y, j) => y.forEach((v, i) => assert.equal(v, rec.u[i][j], `u${j + 1} at step ${i}`)));
  const last = rec.steps - 1;
  const f = await C(page, `c.frame("gap", ${last})`);
  assert.deepEqual(f.q, rec.q[last]);
  assert.deepEqual(f.u, rec.u[last]);
  const readout = await page.locator("[data-testid=cbf-readout]").textContent();
  assert.match(readout, / u6 -?\d/, "the readout shows the last joint's velocity");
  assert.doesNotMatch(readout, /u7/);
  // j cycles all → 1 → … → 6 → all.
  const seen = [];
  for (let k = 0; k < 7; k++) {
    await page.keyboard.press("j");
    seen.push((await C(page, "c.state")).joint);
  }
  assert.deepEqual(seen, [1, 2, 3, 4, 5, 6, 0]);
  assert.deepEqual(page.problems, []);
  await screenshot(page, "cbf-ur5e-joints");
  await page.context().close();
});

test("a finished rollout's record downloads as JSON and CSV", async () => {
  const page = await openView(env.browser, env.server, hash({ duration: 0.3, metric: "gap" }));
  await page.waitForFunction(() => window.distlab?.cbf && /press r|finished|rollout/.test(document.getElementById("status")?.textContent ?? ""), null, { timeout: 60000 });
  await page.keyboard.press("r");
  await runEnded(page, 1);
  const rec = await C(page, 'c.record("gap")');
  const fetchFile = async (testid) => {
    const [download] = await Promise.all([page.waitForEvent("download"), page.click(`[data-testid=${testid}]`)]);
    return { name: download.suggestedFilename(), text: readFileSync(await download.path(), "utf8") };
  };
  const json = await fetchFile("cbf-download-gap-json");
  assert.equal(json.name, "corridor-gap.json");
  assert.deepEqual(JSON.parse(json.text), rec);
  const csv = await fetchFile("cbf-download-gap-csv");
  assert.equal(csv.name, "corridor-gap.csv");
  const rows = csv.text.trim().split("\n").map((l) => l.split(","));
  assert.deepEqual(rows[0].slice(0, 2), ["t", "q1"]);
  assert.equal(rows[0].length, 1 + 7 + 7 + 2);
  assert.equal(rows.length, 1 + rec.t.length);
  rec.t.forEach((t, i) => {
    const row = rows[i + 1].map(Number);
    assert.equal(row[0], t);
    for (let j = 0; j < 7; j++) {
      assert.equal(row[1 + j], rec.q[i][j], `q${j + 1} at step ${i}`);
      assert.equal(row[8 + j], rec.u[i][j], `u${j + 1} at step ${i}`);
    }
    assert.equal(row[15], rec.task_error[i]);
    assert.equal(row[16], rec.min_distance[i]);
  });
  await page.context().close();
});
