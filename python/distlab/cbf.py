"""CBF-QP rollouts of the Franka Panda (paper Section IV-B), GAP or Euclidean distances."""

from __future__ import annotations

from typing import Any, Callable, Mapping, Optional, Union

from . import _core

__all__ = ["solve", "rollout"]


def solve(request: Mapping[str, Any]) -> dict:
    """Runs the ``distlab cbf`` request ``{"scenario", "metric", "params"}`` and returns its
    response (the record, numeric arrays as numpy arrays): the CLI's numbers, bit for bit."""
    return _core.cbf_rollout(dict(request))


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

    Returns the record: ``t`` (S,), ``q`` and ``u`` (S, 7), ``task_error``, ``min_distance``,
    ``distance`` (S, pairs), ``witness_a``/``witness_b`` (S, pairs, 3), ``timing``, ``summary``,
    ``smoothness`` ... (numpy arrays where numeric)."""
    request: dict = {"scenario": scenario if isinstance(scenario, str) else dict(scenario), "metric": metric}
    if params is not None:
        request["params"] = dict(params)
    return _core.cbf_rollout(request, progress, every)
