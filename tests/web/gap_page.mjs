// What the GAP explorer's browser tests share: its test hooks, the wait for a settled readout, the
// state in the URL, and the request for a shape built from that state independently of the page.
import assert from "node:assert/strict";

export const hook = (page, expr) => page.evaluate(`window.distlab.gap.${expr}`);

/** The pentagonal prism of the explorer's "polytope", re-derived here (A x ≤ b). */
export function prism(r, h) {
  const A = [], b = [];
  for (let i = 0; i < 5; i++) {
    const m = Math.PI / 2 + (2 * Math.PI * (i + 0.5)) / 5;
    A.push([Math.cos(m), Math.sin(m), 0]);
    b.push(r * Math.cos(Math.PI / 5));
  }
  A.push([0, 0, 1], [0, 0, -1]);
  b.push(h / 2, h / 2);
  return { type: "polytope", A, b };
}

/** The request for a shape as written in the URL state, built independently of the front end. */
export function shapeFromUrl(s) {
  const body = {
    box: { type: "box", size: s.size },
    sphere: { type: "sphere", radius: s.radius },
    cylinder: { type: "cylinder", radius: s.radius, height: s.height },
    capsule: { type: "capsule", radius: s.radius, height: s.height },
    polytope: prism(s.radius, s.height),
  }[s.type];
  return { ...body, pose: { position: s.position, quaternion: s.quaternion } };
}

export async function urlState(page) {
  await page.waitForFunction(() => location.hash.includes("?s="));
  const hash = await page.evaluate(() => location.hash);
  return JSON.parse(new URLSearchParams(hash.split("?")[1]).get("s"));
}

/** POST /api/gap/distance for a URL state's shapes and parameters (200 asserted). */
export async function direct(server, state, extra = {}) {
  const p = state.params;
  const r = await fetch(server.url + "api/gap/distance", {
    method: "POST",
    headers: { "Content-Type": "application/json" },
    body: JSON.stringify({ a: shapeFromUrl(state.a), b: shapeFromUrl(state.b), params: { h: p.h, k: p.k, eps: p.eps, sigma: p.sigma, solver: p.solver, ...extra } }),
  });
  assert.equal(r.status, 200);
  return r.json();
}

/** Waits until no distance request is in flight and the readout shows a result. */
export async function settled(page) {
  await page.waitForFunction(() => {
    const g = window.distlab?.gap;
    return g && !g.inFlight() && g.D() !== null;
  }, null, { timeout: 30000 });
  await page.waitForTimeout(300); // the URL state is written 150 ms after the last change
  await page.waitForFunction(() => !window.distlab.gap.inFlight());
}
