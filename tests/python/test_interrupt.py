"""Ctrl-C in the middle of long calls: a child interpreter gets SIGINT while inside a batched GAP
call, a Kelvin preparation (in its mesher) and a CBF rollout, sent once the call reported progress;
it raises KeyboardInterrupt before the work finished (judged by the last progress event) and then
runs the same kind of call again."""

import json
import os
import signal
import subprocess
import sys

import pytest

from conftest import ROOT

CHILD = r"""
import json, sys
import numpy as np
from distlab import cbf, gap, kelvin

kind, sphere = sys.argv[1], sys.argv[2]
events, started = [], []

def progress(*args):
    events.append(args)
    # The parent sends SIGINT now: at the first event, for Kelvin once meshing started (the mesher
    # polls the cancellation token; the calling thread must notice the signal meanwhile).
    if not started and (kind != "kelvin" or args[0] == "mesh"):
        started.append(True)
        print("started", flush=True)

def call(small):
    if kind == "gap":
        n = 10 if small else 600_000
        rng = np.random.default_rng(0)
        q = rng.standard_normal((n, 4))
        poses = np.hstack([rng.uniform(-1, 1, (n, 3)) + [2, 0, 0], q / np.linalg.norm(q, axis=1, keepdims=True)])
        r = gap.distance(gap.Box([0.4, 0.3, 0.2]), None, gap.Box([0.2, 0.2, 0.2]), poses,
                         gap.Params(gradient=False), threads=1, progress=progress)
        return float(r.distance.min())
    if kind == "kelvin":
        f = kelvin.Field.prepare(sphere, lx=0.3 if small else 0.02, progress=progress)
        f.set_sigma(constant=0.2)
        return float(f.query([[1.0, 0.0, 0.0]])[0][0])
    r = cbf.rollout("corridor", "gap", {"duration": 0.1 if small else 120.0}, progress=progress, every=5)
    return float(r["t"][-1])

try:
    call(False)
    outcome = "finished"
except KeyboardInterrupt:
    outcome = "interrupted"
last = events[-1] if events else None
events.clear()
print(json.dumps({"outcome": outcome, "last": last, "again": call(True), "events_again": len(events)}), flush=True)
"""


@pytest.mark.parametrize("kind", ["gap", "kelvin", "cbf"])
def test_sigint_stops_the_call_and_leaves_a_usable_interpreter(kind):
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-c", CHILD, kind, str(ROOT / "assets" / "sphere.stl")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        line = proc.stdout.readline()
        assert line.strip() == "started", (line, proc.stderr.read() if proc.poll() is not None else "")
        proc.send_signal(signal.SIGINT)
        out, err = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 0, err
    result = json.loads(out.splitlines()[-1])
    assert result["outcome"] == "interrupted", result
    # Stopped before the work was done (the last progress the call made), not at its end.
    last = result["last"]
    if kind == "gap":
        done, total = last
        assert done < total
    elif kind == "kelvin":
        assert last[0] == "mesh" and last[1] < 0.9, last  # inside the mesher, never reached build
    else:
        step, t = last
        assert t < 120.0
    # The same call runs to completion afterwards, with its progress calls.
    assert result["again"] == result["again"] and result["events_again"] > 0
