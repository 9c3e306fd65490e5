"""CBF-QP rollouts of the Franka Panda (paper Section IV-B), GAP or Euclidean distances."""

from __future__ import annotations

import re
from typing import Any, Callable, List, Mapping, Optional, Sequence, Union

import numpy as np

from . import _core
from . import batch as _batch
from .errors import InvalidInput

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
    *,
    client: Any = None,
    wait: bool = True,
) -> Any:
    """A parameter sweep: one rollout per value with ``params.<parameter> = value``
    (``parameter`` a dotted key of params, e.g. ``"margins.gap.obstacle"``, ``"gap.tol"``,
    ``"duration"``; at most 16 values, any number with ``client``; audit on unless ``params`` says
    otherwise), the runs in parallel on the available cores, each exactly the run alone (the CLI's
    numbers, bit for bit).

    ``progress(stage, fraction)`` as the service's sweep job reports it (stage ``"K of N runs
    done"``, fraction over all runs' steps); Ctrl-C (KeyboardInterrupt) or an exception raised by
    it stops every run and propagates. A bad value raises InvalidInput naming
    ``sweep.values[i]``, a path that is no parameter ``sweep.parameter``.

    Returns ``{"scenario", "metric", "parameter", "values", "entries"}``, ``entries[i]`` the run
    with ``values[i]``: ``index``, ``value``, ``position_error``, ``min_clearance``,
    ``total_variation`` (Σ over joints), ``infeasible_steps``, ``steps``, ``step_us_mean``,
    ``gap_mode``, ``summary`` and ``smoothness`` (as that run's record).

    ``client``: a ``dask.distributed.Client`` (:mod:`distlab.batch`; dask is imported only then):
    one task per value, any number of values, each entry the same as the local sweep's (bit for
    bit but ``step_us_mean``, a timing); ``fraction`` is then the mean of the runs' fractions. A
    bad value raises the same InvalidInput once its task ran (the other tasks are cancelled then).
    With ``wait=False`` the call returns the
    :class:`distlab.batch.Batch` at once (``progress()``, ``wait(progress)``, ``cancel()``,
    ``result()``)."""
    request: dict = {"scenario": scenario if isinstance(scenario, str) else dict(scenario), "metric": metric,
                     "sweep": {"parameter": parameter, "values": list(values)}}
    if params is not None:
        request["params"] = dict(params)
    if client is None:
        if not wait:
            raise ValueError("wait=False needs a client")
        return _core.cbf_sweep(request, progress)
    _batch.require_client(client)
    values = request.pop("sweep")["values"]
    if not values:
        raise InvalidInput("sweep.values", "expected an array of 1 or more values")
    tasks = [(dict(request, sweep={"parameter": parameter, "values": [v]}),) for v in values]
    b = _batch.Batch(client, "cbf-sweep", _sweep_task, tasks, _sweep_combine, _batch.count_report("runs done"),
                     _sweep_error)
    return b.wait(progress) if wait else b


def _sweep_task(request: dict, report: Callable[[float], None]) -> dict:
    """A task of sweep(client=): the sweep of one value, on the worker."""
    return _core.cbf_sweep(request, lambda stage, fraction: report(fraction))


def _sweep_combine(parts: List[dict]) -> dict:
    out = dict(parts[0])
    out["values"] = _join_values([p["values"] for p in parts])
    out["entries"] = [dict(p["entries"][0], index=i) for i, p in enumerate(parts)]
    return out


def _join_values(values: List[Any]) -> Any:
    """The one-value sweeps' "values" as the whole sweep's response has them: the C++ response
    makes a rectangular array of numbers (or of booleans) a numpy array (integers with floats:
    float64), anything else a list of its elements, each converted alone."""
    arrays = all(isinstance(v, np.ndarray) for v in values)
    if arrays and len({v.shape[1:] for v in values}) == 1 and len({v.dtype == bool for v in values}) == 1:
        return np.concatenate(values)
    return [v[0] if isinstance(v, list) or v.ndim > 1 else v[0].item() for v in values]


_VALUE_0 = re.compile(r"^sweep\.values\[0\]")


def _sweep_error(i: int, error: BaseException) -> BaseException:
    """A task's error about its one value (sweep.values[0]) names the value in the whole sweep."""
    if isinstance(error, InvalidInput) and _VALUE_0.match(error.field):
        field = _VALUE_0.sub(f"sweep.values[{i}]", error.field)
        message = error.message.replace("sweep.values[0]", f"sweep.values[{i}]")
        return type(error)(field, message)
    return error


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
