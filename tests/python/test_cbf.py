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


SWEEP = {"scenario": "corridor", "metric": "gap", "params": {"duration": 0.5},
         "sweep": {"parameter": "margins.gap.obstacle", "values": [0.002, 0.0005, 0.0002]}}
SWEEP_TIMINGS = {"step_us_mean"}


def test_sweep_equals_cli_and_the_single_runs(exe):
    code, cli = run_cli("cbf", SWEEP)
    assert code == 0, cli
    ours = cbf.solve(SWEEP)
    assert_same(ours, cli, skip=SWEEP_TIMINGS)
    same = cbf.sweep("corridor", "margins.gap.obstacle", [0.002, 0.0005, 0.0002], "gap", {"duration": 0.5})
    assert_same(same, cli, skip=SWEEP_TIMINGS)
    # The runs go in parallel; each entry is still the run alone, in the sweep's order.
    assert [e["index"] for e in ours["entries"]] == [0, 1, 2]
    for value, entry in zip(SWEEP["sweep"]["values"], ours["entries"]):
        single = cbf.solve({"scenario": "corridor", "metric": "gap",
                            "params": {"duration": 0.5, "audit": True, "margins": {"gap": {"obstacle": value}}}})
        assert entry["value"] == value
        assert_same(entry["summary"], single["summary"])
        assert_same(entry["smoothness"], single["smoothness"])
        assert entry["steps"] == len(single["t"])
        assert entry["total_variation"] == sum(single["smoothness"]["total_variation"])


def test_sweep_progress_in_the_job_vocabulary():
    events = []
    out = cbf.sweep("corridor", "duration", [0.2, 0.4, 0.3], progress=lambda stage, f: events.append((stage, f)))
    assert [e["steps"] for e in out["entries"]] == [20, 40, 30]
    fractions = [f for _, f in events]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    assert events[-1][0] == "3 of 3 runs done"
    assert {s for s, _ in events} <= {f"{k} of 3 runs done" for k in range(4)}


def test_sweep_stops_on_an_exception_in_progress():
    def stop(stage, fraction):
        if fraction > 0.01:
            raise RuntimeError("enough")

    with pytest.raises(RuntimeError, match="enough"):
        cbf.sweep("corridor", "duration", [30.0, 30.0, 30.0], progress=stop)


@pytest.mark.parametrize("parameter,values,field", [
    ("margins.gap.obstacle", [0.002, -1], "sweep.values[1]"),
    ("no_such_setting", [1], "sweep.parameter"),
    ("task_gain", [], "sweep.values"),
])
def test_sweep_bad_input_names_the_field(parameter, values, field):
    with pytest.raises(distlab.InvalidInput) as info:
        cbf.sweep("corridor", parameter, values)
    assert info.value.field == field, str(info.value)
