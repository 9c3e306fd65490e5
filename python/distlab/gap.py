"""The GAP differentiable distance between convex shapes (Gonçalves et al., RA-L 2026).

Shapes are described as the CLI's JSON shapes (each class's :meth:`spec`), so the C++ code that
checks ``distlab gap`` requests checks them too; errors name the field (``a.size[1]``).
Poses: arrays of 7 numbers ``[x, y, z, qw, qx, qy, qz]`` or 4x4 rigid transforms, one pose or
``(N, 7)`` / ``(N, 4, 4)`` for N pairs.
"""

from __future__ import annotations

import dataclasses
from typing import Any, Callable, Mapping, Optional, Sequence

import numpy as np

from . import _core

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
    W_i = 1/(m + ε); tol: Newton stops when the step is below it; max_iter: 0 = solver default
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
             progress: Optional[Callable[[int, int], Any]] = None) -> Result:
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
    type) naming the field."""
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
    out = _core.gap_batch(_shape_spec(a, "a"), pa, _shape_spec(b, "b"), pb, pdict, int(threads), wa, wb, euclidean,
                          progress, track)
    if single_a and single_b:
        out = {k: (None if v is None else (v[0].item() if v.ndim == 1 else v[0])) for k, v in out.items()}
    return Result(out)


def default_params() -> Params:
    """The C++ core's defaults (equal to Params())."""
    return Params(**_core.gap_default_params())
