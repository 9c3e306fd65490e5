"""distlab.cbf against the CLI (bit for bit apart from timings), progress and bad input."""

import numpy as np
import pytest

import distlab
from distlab import cbf
from conftest import assert_same, run_cli

TIMINGS = {"timing"}


@pytest.mark.parametrize("metric", ["gap", "euclidean"])
def test_solve_equals_cli(exe, metric):
    request = {"scenario": "corridor", "metric": metric, "params": {"duration": 0.3}}
    code, cli = run_cli("cbf", request)
    assert code == 0, cli
    ours = cbf.solve(request)
    assert_same(ours, cli, skip=TIMINGS)
    assert ours["q"].shape == (len(ours["t"]), 7)


def test_rollout_record_and_progress():
    calls = []
    rec = cbf.rollout("corridor", "gap", {"duration": 0.2, "record_pairs": True},
                      progress=lambda step, t: calls.append(step), every=5)
    steps = len(rec["t"])
    assert rec["u"].shape == (steps, 7)
    assert rec["witness_a"].shape == (steps, len(rec["pairs"]), 3)
    assert calls == list(range(0, steps, 5))
    # q advances by u dt (the rollout's integrator)
    np.testing.assert_allclose(rec["q"][1:], rec["q"][:-1] + rec["u"][:-1] * rec["dt"], rtol=0, atol=1e-12)


def test_exception_in_progress_stops_the_rollout():
    def stop(step, t):
        if step == 3:
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        cbf.rollout("corridor", "gap", {"duration": 5.0}, progress=stop, every=1)


@pytest.mark.parametrize("request_,field", [
    ({"scenario": "corridor", "metric": "manhattan"}, "metric"),
    ({"scenario": "nowhere", "metric": "gap"}, "scenario"),
    ({"scenario": "corridor", "metric": "gap", "params": {"dt": -1}}, "params.dt"),
])
def test_bad_input_raises_naming_the_field(request_, field):
    with pytest.raises(distlab.InvalidInput) as info:
        cbf.solve(request_)
    assert info.value.field == field, str(info.value)
