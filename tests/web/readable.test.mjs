// Pictures that can be read (issue 17, items 9 and 10): every plot of the GAP and CBF views has
// axes with tick labels and units, a legend and a sentence saying what each curve is (D and d on
// one length axis); overlapping shapes in the GAP view show the Euclidean signed distance and the
// penetration depth beside Λ, equal to the closed form, with the penetration's witness points drawn.
// The CBF joint-velocity plot, whose legend lists only names, shows the values under the cursor.
import { test } from "node:test";
import assert from "node:assert/strict";
import { openView, screenshot, serverAndBrowser } from "./harness.mjs";

const env = serverAndBrowser();

const gapHash = (state) => `#/gap?s=${encodeURIComponent(JSON.stringify(state))}`;
const plots = (page) => page.evaluate(() => window.distlab.plots?.() ?? []);
const hasUnit = (label) => /\(.+\)\s*$/.test(label);

async function settled(page) {
  await page.waitForFunction(() => {
    const g = window.distlab?.gap;
    return g && !g.inFlight() && g.result() !== null;
  }, null, { timeout: 60000 });
}

/** Axes labelled with a unit and drawn with at least two tick labels; a legend; a caption. */
function readable(p, what) {
  assert.ok(p.axes.length >= 2, `${what}: x and y axes (${JSON.stringify(p.axes)})`);
  for (const a of p.axes) {
    assert.ok(hasUnit(a.label), `${what}: axis "${a.label}" names its unit`);
    assert.ok(a.ticks.length >= 2, `${what}: axis "${a.label}" has tick labels (${a.ticks.join(", ")})`);
  }
  assert.ok(p.legend.length >= 1, `${what}: a legend`);
  assert.match(p.caption, /^\S.{20,}\.$/, `${what}: one sentence saying what each curve is`);
}

test("GAP sweep plots: D and d on one length axis, units that follow the motion, legends, captions", async () => {
  const page = await openView(env.browser, env.server, "#/gap");
  await settled(page);
  await page.waitForFunction(() => window.distlab.gap.sweep().data !== null, null, { timeout: 60000 });
  let ps = await plots(page);
  assert.equal(ps.length, 2, "the distance plot and the derivative plot");
  ps.forEach((p, i) => readable(p, `GAP plot ${i}`));
  const [d, deriv] = ps;
  assert.equal(d.axes.length, 2, "D and d share one y axis (both are lengths)");
  assert.equal(d.axes[1].label, "distance (m)");
  assert.deepEqual(d.legend, ["s (m)", "GAP D", "Euclidean d"]);
  assert.match(d.caption, /GAP D/);
  assert.match(d.caption, /Euclidean signed distance d/);
  assert.equal(deriv.axes[1].label, "dD/ds (m/m)");
  assert.match(deriv.caption, /dD\/ds/);
  await page.context().close();

  // A rotation: s in radians, the derivative in m/rad.
  const rot = await openView(env.browser, env.server, gapHash({ sweep: { motion: "rotate", axis: "z", range: 0.3, samples: 41 } }));
  await settled(rot);
  await rot.waitForFunction(() => window.distlab.gap.sweep().data !== null, null, { timeout: 60000 });
  await rot.waitForFunction(() => window.distlab.plots()[0].axes[0].label === "s (rad)", null, { timeout: 30000 });
  ps = await plots(rot);
  ps.forEach((p, i) => readable(p, `GAP rotation plot ${i}`));
  assert.equal(ps[1].axes[1].label, "dD/ds (m/rad)");
  await screenshot(rot, "readable-gap-plots");
  assert.deepEqual(rot.problems, []);
  await rot.context().close();
});

test("CBF rollout plots: velocity, distance, task error and pair distances with units, legends and captions", async () => {
  const page = await openView(env.browser, env.server, `#/cbf?s=${encodeURIComponent(JSON.stringify({ duration: 0.5 }))}`);
  await page.waitForFunction(() => /press r|finished|running|rollout/.test(document.getElementById("status")?.textContent ?? ""), null, { timeout: 60000 });
  await page.keyboard.press("r");
  await page.waitForFunction(
    () => {
      const r = window.distlab?.cbf?.rollouts;
      return !!r && r.length > 0 && r.every((x) => ["finished", "cancelled", "failed"].includes(x.state));
    },
    null,
    { timeout: 120000 },
  );
  await page.waitForFunction(() => (window.distlab.plots?.() ?? []).length === 4 && window.distlab.plots().every((p) => p.axes.every((a) => a.ticks.length > 1)), null, { timeout: 30000 });
  const ps = await plots(page);
  ps.forEach((p, i) => readable(p, `CBF plot ${i} (${p.title})`));
  const ylabels = ps.map((p) => p.axes[1].label);
  assert.deepEqual(ylabels, ["u (rad/s)", "distance (m)", "‖r‖ (m, 1 − cos)", "D (m)"]);
  assert.deepEqual(ps.map((p) => p.axes[0].label), ["t (s)", "t (s)", "t (s)", "pair (#)"]);
  assert.ok(ps[1].legend.some((l) => l.startsWith("clearance")) && ps[1].legend.some((l) => l.startsWith("min D")), "clearance and min D in one plot");
  await screenshot(page, "readable-cbf-plots");
  assert.deepEqual(page.problems, []);
  await page.context().close();
});

test("CBF joint velocities: the values under the cursor are shown beside it, those of the plotted series", async () => {
  const page = await openView(env.browser, env.server, `#/cbf?s=${encodeURIComponent(JSON.stringify({ duration: 0.5 }))}`);
  await page.waitForFunction(() => /press r/.test(document.getElementById("status")?.textContent ?? ""), null, { timeout: 60000 });
  await page.keyboard.press("r");
  await page.waitForFunction(
    () => {
      const r = window.distlab?.cbf?.rollouts;
      return !!r && r.length > 0 && r.every((x) => ["finished", "cancelled", "failed"].includes(x.state)) && document.getElementById("progress").hidden;
    },
    null,
    { timeout: 120000 },
  );
  const plot = page.locator("#bottom .plot", { has: page.locator(".u-title", { hasText: "joint velocities" }) });
  const over = await plot.locator(".u-over").boundingBox();
  await page.mouse.move(over.x + over.width * 0.6, over.y + over.height * 0.5);
  const box = plot.locator(".plot-cursor-values");
  const shown = await box
    .waitFor({ state: "visible", timeout: 10000 })
    .then(
      () => true,
      () => false,
    );
  assert.ok(shown, "hovering the joint-velocity plot shows the values at the cursor");
  const rows = await box.locator(":scope > div").allTextContents();
  const t = Number(/^t \(s\) = (\S+)$/.exec(rows[0])?.[1]);
  const { velocity } = await page.evaluate(() => window.distlab.cbf.plots());
  const i = velocity.x.findIndex((x) => Math.abs(x - t) < 1e-9);
  assert.ok(i > 0, `the cursor's time ${t} s is a plotted step (${rows[0]})`);
  const expected = velocity.labels.flatMap((label, k) => (velocity.y[k][i] === null ? [] : [`${label}: ${velocity.y[k][i].toFixed(4)}`]));
  assert.ok(expected.length >= 7, "a value per joint at least");
  assert.deepEqual(rows.slice(1), expected, "each series' value at that step, named as in the legend");
  // Showing one joint (j): only its values.
  await page.keyboard.press("j");
  await page.mouse.move(over.x + over.width * 0.6, over.y + over.height * 0.4);
  await page.waitForFunction(() => document.querySelector(".plot-cursor-values")?.children.length < 4);
  const one = await box.locator(":scope > div").allTextContents();
  assert.ok(one.slice(1).every((r) => /^u1 /.test(r)), `joint 1 only: ${one}`);
  await screenshot(page, "readable-cbf-velocity-cursor");
  await page.mouse.move(2, 2);
  await box.waitFor({ state: "hidden" });
  assert.deepEqual(page.problems, []);
  await page.context().close();
});

test("overlapping spheres: signed distance and penetration depth equal the closed form; witness points drawn", async () => {
  // Spheres r = 0.3 and 0.25, centres 0.4 apart along (1, 2, 2)/3: depth 0.3 + 0.25 − 0.4 = 0.15.
  const e = [1 / 3, 2 / 3, 2 / 3];
  const c1 = [0.1, 0, 0], L = 0.4, r1 = 0.3, r2 = 0.25;
  const c2 = c1.map((v, i) => v + L * e[i]);
  const shape = (r, c) => ({ type: "sphere", radius: r, size: [0.3, 0.3, 0.3], height: 0.3, position: c, quaternion: [1, 0, 0, 0] });
  const page = await openView(env.browser, env.server, gapHash({ a: shape(r1, c1), b: shape(r2, c2), iso: { surfaces: "none", slice: "none" } }));
  await settled(page);
  const r = await page.evaluate(() => window.distlab.gap.result());
  assert.equal(r.overlap, true);
  const pen = r.euclidean.penetration;
  assert.ok(pen, "the response carries the penetration");
  const depth = r1 + r2 - L;
  assert.ok(Math.abs(pen.depth - depth) < 1e-9, `depth ${pen.depth} = r1 + r2 − |c1 − c2| = ${depth}`);
  assert.ok(Math.hypot(...pen.direction.map((v, i) => v - e[i])) < 1e-6, `direction ${pen.direction} along the centre line`);
  assert.equal(r.euclidean.signed_distance, -pen.depth);

  const field = async (f) => (await page.locator(`.gap-readout [data-field=${f}]`).textContent()) ?? "";
  assert.match(await field("euclid-signed"), new RegExp(`signed d = ${(-pen.depth).toPrecision(6).replace(".", "\\.")} m`));
  assert.match(await field("euclid-pen"), new RegExp(`penetration depth = ${pen.depth.toPrecision(6).replace(".", "\\.")} m`));
  assert.match(await field("gap-lambda"), /Λ = 0(\.0+)? m²/, "Λ = 0 beside it");
  assert.match(await page.locator(".gap-legend").textContent(), /penetration witness points/);

  // The witness points drawn are the penetration's: A's deepest point in B and B's in A.
  const drawn = await page.evaluate(() => window.distlab.gap.drawn());
  assert.ok(drawn.pen, "penetration witness points are drawn");
  assert.deepEqual(drawn.pen, [pen.witness_a, pen.witness_b]);
  const wa = c1.map((v, i) => v + r1 * e[i]), wb = c2.map((v, i) => v - r2 * e[i]);
  assert.ok(Math.hypot(...drawn.pen[0].map((v, i) => v - wa[i])) < 1e-6, "a: c1 + r1 e");
  assert.ok(Math.hypot(...drawn.pen[1].map((v, i) => v - wb[i])) < 1e-6, "b: c2 − r2 e");
  await screenshot(page, "readable-gap-penetration");

  // Pulled apart (by a shared URL): no penetration, signed d = d, the penetration points hidden.
  const far = c1.map((v, i) => v + 1.0 * e[i]);
  const apart = await openView(env.browser, env.server, gapHash({ a: shape(r1, c1), b: shape(r2, far), iso: { surfaces: "none", slice: "none" } }));
  await settled(apart);
  const ra = await apart.evaluate(() => window.distlab.gap.result());
  assert.equal(ra.euclidean.penetration, undefined);
  assert.ok(Math.abs(ra.euclidean.signed_distance - (1.0 - r1 - r2)) < 1e-9);
  assert.equal((await apart.evaluate(() => window.distlab.gap.drawn())).pen, null);
  assert.equal(await apart.locator(".gap-readout [data-field=euclid-pen]").count(), 0);
  assert.deepEqual(page.problems, []);
  assert.deepEqual(apart.problems, []);
  await page.context().close();
  await apart.context().close();
});
