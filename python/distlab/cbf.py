"""CBF-QP rollouts of the Franka Panda (paper Section IV-B), GAP or Euclidean distances."""

from __future__ import annotations

from typing import Any, Callable, Mapping, Optional, Sequence, Union

from . import _core

__all__ = ["solve", "rollout", "sweep"]


def solve(request: Mapping[str, Any], progress: Optional[Callable[[str, float], Any]] = None) -> dict:
    """Runs the ``distlab cbf`` request ``{"scenario", "metric", "params"}`` and returns its
    response (the record, numeric arrays as numpy arrays): the CLI's numbers, bit for bit. A
    request with ``"sweep": {"parameter", "values"}`` is a parameter sweep, answered as
    :func:`sweep` answers it (``progress(stage, fraction)`` applies to sweeps only)."""
    if "sweep" in request:
        return _core.cbf_sweep(dict(request), progress)
    return _core.cbf_rollout(dict(request))


def sweep(
    scenario: Union[str, Mapping[str, Any]],
    parameter: str,
    values: Sequence[Any],
    metric: str = "gap",
    params: Optional[Mapping[str, Any]] = None,
    progress: Optional[Callable[[str, float], Any]] = None,
) -> dict:
    """A parameter sweep: one rollout per value with ``params.<parameter> = value``
    (``parameter`` a dotted key of params, e.g. ``"margins.gap.obstacle"``, ``"gap.tol"``,
    ``"duration"``; at most 16 values; audit on unless ``params`` says otherwise), the runs in
    parallel on the available cores, each exactly the run alone (the CLI's numbers, bit for bit).

    ``progress(stage, fraction)`` as the service's sweep job reports it (stage ``"K of N runs
    done"``, fraction over all runs' steps); Ctrl-C (KeyboardInterrupt) or an exception raised by
    it stops every run and propagates. A bad value raises InvalidInput naming
    ``sweep.values[i]``, a path that is no parameter ``sweep.parameter``.

    Returns ``{"scenario", "metric", "parameter", "values", "entries"}``, ``entries[i]`` the run
    with ``values[i]``: ``index``, ``value``, ``position_error``, ``min_clearance``,
    ``total_variation`` (Σ over joints), ``infeasible_steps``, ``steps``, ``step_us_mean``,
    ``gap_mode``, ``summary`` and ``smoothness`` (as that run's record)."""
    request: dict = {"scenario": scenario if isinstance(scenario, str) else dict(scenario), "metric": metric,
                     "sweep": {"parameter": parameter, "values": list(values)}}
    if params is not None:
        request["params"] = dict(params)
    return _core.cbf_sweep(request, progress)


def rollout(
    scenario: Union[str, Mapping[str, Any]],
    metric: str = "gap",
    params: Optional[Mapping[str, Any]] = None,
    progress: Optional[Callable[[int, float], Any]] = None,
    every: int = 10,
) -> dict:
    """One rollout. ``scenario``: a name of assets/scenarios (e.g. ``"corridor"``; found through
    $DISTLAB_ASSETS or ./assets) or a scenario dict; ``metric``: ``"gap"`` or ``"euclidean"``;
    ``params``: the CLI's overrides (dt, duration, q0, gap {...}, record_pairs, audit, ...).
    ``progress(step, t)`` is called every ``every`` steps; Ctrl-C (KeyboardInterrupt) or an
    exception raised by it stops the rollout and propagates.

    Returns the record: ``t`` (S,), ``q`` and ``u`` (S, dof), ``task_error``, ``min_distance``,
    ``distance`` (S, pairs), ``witness_a``/``witness_b`` (S, pairs, 3), ``timing``, ``summary``,
    ``smoothness`` ... (numpy arrays where numeric)."""
    request: dict = {"scenario": scenario if isinstance(scenario, str) else dict(scenario), "metric": metric}
    if params is not None:
        request["params"] = dict(params)
    return _core.cbf_rollout(request, progress, every)
