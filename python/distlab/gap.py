"""The GAP differentiable distance between convex shapes (Gonçalves et al., RA-L 2026).

Shapes are described as the CLI's JSON shapes (each class's :meth:`spec`), so the C++ code that
checks ``distlab gap`` requests checks them too; errors name the field (``a.size[1]``).
Poses: arrays of 7 numbers ``[x, y, z, qw, qx, qy, qz]`` or 4x4 rigid transforms, one pose or
``(N, 7)`` / ``(N, 4, 4)`` for N pairs.
"""

from __future__ import annotations

import dataclasses
import re
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence

import numpy as np

from . import _core
from . import batch as _batch
from .errors import InvalidInput

__all__ = ["Box", "Sphere", "Cylinder", "Capsule", "Polytope", "ConvexHull", "Params", "Result",
           "distance", "solve"]


def solve(request: Mapping[str, Any]) -> dict:
    """Runs a ``distlab gap`` request (``{"a", "b", "params"}`` or ``{"pairs", "params"}``) and
    returns its response as a dict, numeric arrays as numpy arrays: the CLI's numbers, bit for bit."""
    return _core.gap_solve(dict(request))


class Shape:
    """A convex shape in its own frame. ``weights`` (polytopes, boxes) and ``rho``
    (``(center, radius)``, the ρ ball in the shape frame) are the CLI's optional keys."""

    def __init__(self, weights=None, rho=None):
        self.weights = weights
        self.rho = rho

    def _spec(self) -> dict:
        raise NotImplementedError

    def spec(self) -> dict:
        """The shape as the CLI's JSON object (without a pose)."""
        s = self._spec()
        if self.weights is not None:
            s["weights"] = self.weights
        if self.rho is not None:
            center, radius = self.rho
            s["rho"] = {"center": center, "radius": radius}
        return s

    def __repr__(self):
        return f"{type(self).__name__}({self._spec()})"


class Box(Shape):
    """A box of full edge lengths ``size`` = (x, y, z), centred at the origin."""

    def __init__(self, size: Sequence[float], weights=None, rho=None):
        super().__init__(weights, rho)
        self.size = size

    def _spec(self):
        return {"type": "box", "size": self.size}


class Sphere(Shape):
    """A ball of the given radius at the origin."""

    def __init__(self, radius: float, rho=None):
        super().__init__(None, rho)
        self.radius = radius

    def _spec(self):
        return {"type": "sphere", "radius": self.radius}


class Cylinder(Shape):
    """A cylinder along z: ``radius``, full length ``height``."""

    def __init__(self, radius: float, height: float, rho=None):
        super().__init__(None, rho)
        self.radius, self.height = radius, height

    def _spec(self):
        return {"type": "cylinder", "radius": self.radius, "height": self.height}


class Capsule(Shape):
    """A capsule along z: ``radius``, core segment length ``height`` (total height + 2 radius)."""

    def __init__(self, radius: float, height: float, rho=None):
        super().__init__(None, rho)
        self.radius, self.height = radius, height

    def _spec(self):
        return {"type": "capsule", "radius": self.radius, "height": self.height}


class Polytope(Shape):
    """The bounded polytope {x : A x <= b}; ``A`` (m, 3), ``b`` (m,), optional ``weights`` (m,)."""

    def __init__(self, A, b, weights=None, rho=None):
        super().__init__(weights, rho)
        self.A, self.b = A, b

    def _spec(self):
        return {"type": "polytope", "A": self.A, "b": self.b}


class ConvexHull(Shape):
    """The convex hull of ``points`` (n, 3) (computed exactly; its facets become a polytope)."""

    def __init__(self, points, weights=None, rho=None):
        super().__init__(weights, rho)
        self.points = points

    def _spec(self):
        return {"type": "convex_hull", "points": self.points}


@dataclasses.dataclass
class Params:
    """GAP parameters; the defaults are the README's (the paper's robot experiment).

    h: smoothing of Φ (eq. 4), > 0; k: differentiability order, 2...12; eps: ε of eq. 6 in
    (0, 0.5); sigma: σ of eq. 6 in (0, 1), √(1 − 2ε) by default; weight_margin: the ε of
    W_i = 1/(m + ε) (a convex_hull, or above 64 rows: by facet area, see the README); tol: Newton
    stops when its step, or the error it estimates is left after that step, is below it
    (witnesses within tol); max_iter: 0 = solver default
    (100 Newton, 100000 plain); solver: "newton" or "fixed_point"; gradient: also compute
    dD/d(v, ω); validate: check Property 2 on each shape first and refuse if it fails.
    euclidean (not a CLI parameter): False skips FCL's certified Euclidean distance; the solver
    then starts from an uncertified GJK answer (as distlab-bench-gap times it) and the
    euclidean_* outputs are NaN."""

    h: float = 0.1
    k: int = 2
    eps: float = 0.01
    sigma: float = 0.9899494936611665
    weight_margin: float = 0.01
    tol: float = 1e-10
    max_iter: int = 0
    solver: str = "newton"
    gradient: bool = True
    validate: bool = True
    euclidean: bool = True

    def to_dict(self) -> dict:
        """The CLI's "params" object."""
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self) if f.name != "euclidean"}


class Result(dict):
    """Distances of N pairs (or one, with ``N`` dropped: scalars and (3,)/(6,) arrays):
    ``lambda`` Λ (eq. 3), ``distance`` D = √(2Λ), ``witness_a``/``witness_b`` (N, 3),
    ``gradient_a``/``gradient_b`` (N, 6): dD/d(v, ω) (world frame, ω about the shape's origin;
    None with gradient off), ``iterations``, ``converged``, ``overlap`` (N,), and FCL's Euclidean
    ``euclidean_distance``, ``euclidean_witness_a``/``_b``, ``euclidean_gradient_a``/``_b``
    (NaN with warm starts, which skip it), and with warm starts ``track`` (N, 54): each pair's solver
    state for the next warm start (else None). Keys are also attributes (``r.distance``)."""

    def __getattr__(self, name):
        try:
            return self[name]
        except KeyError:
            raise AttributeError(name) from None


def _shape_spec(shape, field: str) -> dict:
    if isinstance(shape, Shape):
        return shape.spec()
    if isinstance(shape, Mapping):
        return dict(shape)
    raise TypeError(f"{field}: expected a distlab.gap shape or a shape dict, got {type(shape).__name__}")


def _poses(pose, field: str):
    """(N, 7) or (N, 4, 4) float64, and whether a single pose was given."""
    if pose is None:
        return np.array([[0, 0, 0, 1, 0, 0, 0]], dtype=np.float64), True
    p = np.asarray(pose, dtype=np.float64)
    if p.shape in ((7,), (4, 4)):
        return p[None], True
    return np.ascontiguousarray(p), False


def distance(a, pose_a, b, pose_b, params: Optional[Params] = None, *, threads: int = 0,
             warm_start: Optional[Mapping[str, Any]] = None,
             progress: Optional[Callable[[int, int], Any]] = None,
             client: Any = None, chunk: Optional[int] = None, wait: bool = True) -> Any:
    """The GAP distance between shape ``a`` at ``pose_a`` and ``b`` at ``pose_b``.

    One pose each gives one result; ``(N, 7)`` or ``(N, 4, 4)`` poses give N results (a single
    pose on one side is shared by all N). Batches run on ``threads`` threads (0: all cores) with
    the GIL released. ``warm_start``: a previous Result (or ``{"witness_a", "witness_b"}`` arrays
    of the same N): Newton starts at those witnesses and skips FCL, for sequences of nearby poses;
    a warm-started Result's ``track`` lets the next call predict each pair's witnesses for its
    new poses (fewer Newton steps along a sequence, the same answers within tolerance).
    ``progress(done, total)`` is called about every 0.1 s and at the end; Ctrl-C
    (KeyboardInterrupt), or an exception raised by ``progress``, stops the batch and propagates.
    Bad input raises :class:`distlab.InvalidInput` (a ValueError; also a TypeError for a wrong
    type) naming the field.

    ``client``: a ``dask.distributed.Client`` (:mod:`distlab.batch`; dask is imported only then):
    the pairs go to the workers in chunks of ``chunk`` pairs (default: about 512 kB of poses,
    witnesses and tracks per chunk), each chunk one call on ``threads`` threads of its worker (0
    there: 1, as a worker runs one task per thread), and the Result is the same as the local
    call's, bit for bit, in the input's order; ``progress(done, total)`` counts the pairs of all
    chunks, and an error names the pair in the whole batch (``pose_b[12345]``). With
    ``wait=False`` the call returns the :class:`distlab.batch.Batch` at once (``progress()``,
    ``wait(progress)``, ``cancel()``, ``result()``: the Result)."""
    pa, single_a = _poses(pose_a, "pose_a")
    pb, single_b = _poses(pose_b, "pose_b")
    params = Params() if params is None else params
    pdict = params.to_dict() if isinstance(params, Params) else dict(params)
    euclidean = bool(pdict.pop("euclidean", True)) and getattr(params, "euclidean", True)
    wa = wb = track = None
    if warm_start is not None:
        wa = np.asarray(warm_start["witness_a"], dtype=np.float64).reshape(-1, 3)
        wb = np.asarray(warm_start["witness_b"], dtype=np.float64).reshape(-1, 3)
        if warm_start.get("track") is not None:
            track = np.asarray(warm_start["track"], dtype=np.float64).reshape(len(wa), -1)
    spec_a, spec_b = _shape_spec(a, "a"), _shape_spec(b, "b")
    if client is None:
        if not wait:
            raise ValueError("wait=False needs a client")
        out = _core.gap_batch(spec_a, pa, spec_b, pb, pdict, int(threads), wa, wb, euclidean, progress, track)
        return _result(out, single_a and single_b)
    _batch.require_client(client)

    def rows(x):
        return x.shape[0] if x.ndim else -1

    # Pairs: the rows of the poses that are not one pose (broadcast), one when both are.
    n = next((rows(x) for x in (pa, pb) if rows(x) != 1), 1)
    per_pair = [x for x in (pa, pb) if rows(x) != 1] + [x for x in (wa, wb, track) if x is not None]
    if all(rows(x) == n for x in per_pair) and min(rows(pa), rows(pb)) >= 0:
        if chunk is None:
            row_bytes = sum(x[0].nbytes for x in per_pair if len(x)) or 56
            chunk = max(256, (512 << 10) // row_bytes)
        if int(chunk) < 1:
            raise InvalidInput("chunk", "chunk must be at least 1 pair")
        starts = list(range(0, n, int(chunk))) or [0]
        ends = starts[1:] + [n]
    else:  # arrays that do not line up: the local call names the field, here, before any task
        _core.gap_batch(spec_a, pa, spec_b, pb, pdict, 1, wa, wb, euclidean, _refuse_to_compute, track)
        raise AssertionError("gap_batch accepted poses that do not line up")  # it checks them first

    def part(x, s, e):
        return x if not any(x is y for y in per_pair) else np.ascontiguousarray(x[s:e])

    tasks = [(spec_a, part(pa, s, e), spec_b, part(pb, s, e), pdict, int(threads) or 1, part(wa, s, e),
              part(wb, s, e), euclidean, part(track, s, e)) for s, e in zip(starts, ends)]
    b = _batch.Batch(client, "gap-distance", _distance_task, tasks,
                     lambda parts: _result(_concatenate(parts), single_a and single_b),
                     _batch.sum_report([e - s for s, e in zip(starts, ends)]),
                     lambda i, error: _chunk_error(starts[i], error))
    return b.wait(progress) if wait else b


def _refuse_to_compute(done: int, total: int) -> None:
    raise AssertionError("gap_batch started on poses that do not line up")


def _result(out: Dict[str, Any], single: bool) -> Result:
    if single:
        out = {k: (None if v is None else (v[0].item() if v.ndim == 1 else v[0])) for k, v in out.items()}
    return Result(out)


def _distance_task(spec_a, pa, spec_b, pb, pdict, threads, wa, wb, euclidean, track, report) -> dict:
    """A task of distance(client=): one chunk of pairs, on the worker."""
    return _core.gap_batch(spec_a, pa, spec_b, pb, pdict, threads, wa, wb, euclidean,
                           lambda done, total: report(done), track)


def _concatenate(parts: List[dict]) -> dict:
    return {k: None if v is None else np.concatenate([p[k] for p in parts]) for k, v in parts[0].items()}


_PAIR_FIELD = re.compile(r"^(pose_a|pose_b|warm_start\.witness_a|warm_start\.witness_b)\[(\d+)\]")


def _chunk_error(start: int, error: BaseException) -> BaseException:
    """A chunk's error about its pair k names pair start + k of the whole batch."""
    m = _PAIR_FIELD.match(error.field) if isinstance(error, InvalidInput) else None
    if m is None or start == 0:
        return error
    local, whole = m.group(0), f"{m.group(1)}[{start + int(m.group(2))}]"
    return type(error)(whole + error.field[m.end():], error.message.replace(local, whole))


def default_params() -> Params:
    """The C++ core's defaults (equal to Params())."""
    return Params(**_core.gap_default_params())
