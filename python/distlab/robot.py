"""Robots as a library: a URDF robot's forward kinematics, and every robot–obstacle and self
distance with its exact gradient in joint space, for one configuration or a batch of them.

    robot = Robot.load("panda")                      # or Robot.from_urdf("arm.urdf", {"pkg": "/path"})
    box = {"type": "box", "size": [0.3, 0.1, 0.9], "pose": {"position": [0.5, 0.2, 0.5]}, "name": "wall"}
    d = robot.distances(q, [box], metric="gap", pairs="both")
    d.distance, d.jacobian, d.pairs                  # (N, P), (N, P, dof), the pair table
    d = robot.distances(q_next, [box], pairs="both", warm_start=d)   # a control loop: tracked
    A, b = robot.cbf_rows(q, [box])                  # A u >= b for your own QP
    wrench = robot.field_barrier([{"mesh": {"asset": "wrench"}, "lx": 0.002, "sigma": {...}, "delta": 0.2,
                                   "pose": {"position": [0.5, 0, 0.0025]}}],
                                 [{"link": "panda_leftfinger", "sample": 16}])
    h, grad = wrench.evaluate(q)                     # a Kelvin field as a barrier: h and ∇_q h
    A, b = robot.cbf_rows(q, [box], fields=wrench)   # its rows between the pairs and the joint limits

**Shapes of q and of the results.** ``q`` is one configuration ``(dof,)`` or a batch ``(N, dof)``
(joints in :attr:`Robot.joint_names` order). A batch gives arrays with a leading N axis; one
configuration gives the same arrays with that axis removed (``distance`` ``(P,)``,
``jacobian`` ``(P, dof)``, ``fk`` ``(L, 7)``, ``cbf_rows`` ``A`` ``(R, dof)``, ...).

**Obstacles** are GAP request shapes (the dicts :func:`distlab.gap.solve` takes, e.g. a
``distlab.gap`` shape's ``spec()`` with a ``"pose"`` added), each with its world ``"pose"``
(``{"position": [x, y, z], "quaternion": [w, x, y, z]}``, either part optional: the identity) and
an optional ``"name"`` of 1 to 64 characters (default ``"obstacle<i>"``, i its index, as in the
CBF scenarios and ``POST /api/robot/distances``). Names are distinct, since they name the pairs:
a repeated one, given or default, raises :class:`distlab.InvalidInput` naming
``"obstacles[i].name"``; other bad input names its field too (``"obstacles[1].size[0]"``). GAP weights: a box
without ``"weights"`` (an obstacle or a robot's ``<box>``) gets W = 1/(1 + weight_margin) on
each face, as in the CBF scenarios, where the Property 2 validator accepts that weight for the
box and the params, else (thin walls, large floors) the gap library's general-polytope default
1/(3 + weight_margin); other shapes get the gap library's defaults, so a mesh element's distance
is the ``convex_hull`` request's. Shapes far smaller than ``h`` (a millimetre box with h = 0.1)
break Property 2 under any weight: a robot's collision element that does takes its own, smaller
``h`` where the validator accepts it (a ``UserWarning`` names it and gives that h; its distances
are sharper than the other elements'). An element large against ``h`` (a 1 m cylinder or box
at h = 0.1) that breaks it takes its own, smaller ``eps`` the same way. An obstacle that breaks
it is refused by ``validate``, naming it; other params (a smaller ``h`` for a small one, a
smaller ``eps`` for a large one) or the Euclidean metric take it.

**Witness points.** Euclidean: the nearest points of the two shapes. GAP: the solution (a*, b*)
of the metric's min–max (the alternating projection's fixed point, eq. 2), which lies near the
shapes but not on their surfaces; ‖a* − b*‖ is not D.

**The order of the pairs** (the P axis): first the robot–obstacle pairs, collision element
major: for each collision element in :attr:`Robot.collision_elements` order (links in URDF file
order, each link's ``<collision>`` elements in file order), every obstacle in the order given;
then the self pairs ``(i, j)``, ``i < j`` indices into :attr:`Robot.collision_elements`, in
lexicographic order. :attr:`Distances.pairs` is that table.

**Models are cached.** The GAP bodies and FCL geometry of a (obstacles, metric, pairs, params)
combination are built (and with ``validate`` checked) on the first call and kept in the Robot
(the last 8 combinations, compared by value), so a control loop calling ``distances(q,
obstacles)`` every millisecond with the same obstacles builds them once. An obstacle that moved
is another combination: one rebuild per call (0.2–0.3 ms for the Panda and three boxes with
GAP, 0.05 ms Euclidean; ~7 ms for the Kinova's 11 mesh hulls; medians measured beside other work).
The costly part of a mesh hull, its weights and its Property 2 verdict (seconds each), is kept
per hull for the process, and its FCL geometry is built once when the robot is loaded, so only
the first model of a robot pays them.
"""

from __future__ import annotations

import os
import warnings
from typing import Any, Mapping, Optional, Sequence, Union

import numpy as np

from . import _core
from .errors import FieldUndefined, InvalidInput, InvalidInputType

__all__ = ["Robot", "Distances", "CbfRows", "FieldBarrier"]

PairsArg = Union[str, Mapping[str, Any]]


def _threads(threads) -> int:
    if isinstance(threads, bool) or not isinstance(threads, (int, np.integer)):
        raise InvalidInputType("threads", f"threads must be an integer >= 0 (0: every core), got {type(threads).__name__}")
    if threads < 0:
        raise InvalidInput("threads", f"threads must be >= 0 (0: every core), got {threads}")
    return int(threads)


def _q_array(q) -> np.ndarray:
    try:
        a = np.ascontiguousarray(q, dtype=np.float64)
    except (TypeError, ValueError) as e:
        raise InvalidInputType("q", f"q must be an array of numbers: {e}") from None
    return a


def _params(params):
    if params is None or isinstance(params, Mapping):
        return None if params is None else dict(params)
    if hasattr(params, "to_dict"):  # distlab.gap.Params
        return params.to_dict()
    raise InvalidInputType("params", f"params must be a dict, a distlab.gap.Params or None, got {type(params).__name__}")


def _obstacles(obstacles):
    if obstacles is None:
        return []
    if isinstance(obstacles, Mapping):
        raise InvalidInputType("obstacles", "obstacles must be a list of shape dicts (one obstacle: [shape])")
    return obstacles if isinstance(obstacles, list) else list(obstacles)


def _state(warm_start):
    if warm_start is None or isinstance(warm_start, _core.RobotState):
        return warm_start
    state = getattr(warm_start, "state", None)
    if isinstance(state, _core.RobotState):
        return state
    raise InvalidInputType("warm_start", "warm_start must be a previous Distances or CbfRows result, its .state, or None, "
                                         f"got {type(warm_start).__name__}")


class Distances:
    """Every pair's distance at every configuration (leading N axis absent for one configuration):

    - ``distance`` ``(N, P)``: D (GAP, sqrt(2Λ)) or the Euclidean distance; 0 on overlap.
    - ``jacobian`` ``(N, P, dof)``: dD/dq, exact (the pose gradients through the point
      Jacobians).
    - ``witness_robot`` ``(N, P, 3)``: the robot side's witness point (world): the nearest point of
      the collision element (Euclidean) or the metric's a* (GAP: near the element, not on it).
    - ``witness_obstacle`` ``(N, P, 3)``: the same for the obstacle, or the self pair's second element.
    - ``obstacle_gradient`` ``(N, P, 6)``: dD/d(v, ω) of the obstacle (world frame, ω about the
      obstacle's origin), zeros for self pairs and on overlap: with a moving obstacle's twist
      (v, ω), ``dD/dt = jacobian @ qdot + obstacle_gradient @ [v, ω]`` (a time-varying CBF's term).
    - ``overlap``, ``converged`` ``(N, P)`` bool; ``iterations`` ``(N, P)`` int (GAP Newton steps).
    - ``pairs``: the pair table, one dict per pair in the order of the P axis: ``name``
      (``"ELEMENT/OBSTACLE"`` or ``"ELEMENT/ELEMENT"``), ``self``, ``link``, ``element`` (its index
      among the link's ``<collision>`` elements), ``element_name``, ``obstacle`` (index into the
      obstacles given; None for self pairs), ``obstacle_name``, and for self pairs ``other_link``,
      ``other_element``, ``other_element_name`` (None for obstacle pairs).
    - ``state``: the GAP solver's state after the last configuration; pass this result (or the
      state) as ``warm_start=`` of the next call to continue the tracked warm start.
    """

    __slots__ = ("distance", "jacobian", "witness_robot", "witness_obstacle", "overlap", "converged", "iterations",
                 "state", "obstacle_gradient", "_pairs")

    def __init__(self, arrays: tuple, single: bool):
        if single:
            arrays = tuple(a[0] for a in arrays[:7]) + (arrays[7], arrays[8][0])
        (self.distance, self.jacobian, self.witness_robot, self.witness_obstacle, self.overlap, self.converged,
         self.iterations, self.state, self.obstacle_gradient) = arrays
        self._pairs = None

    @property
    def pairs(self) -> list:
        if self._pairs is None:
            self._pairs = self.state.pairs()
        return self._pairs

    @property
    def names(self) -> list:
        """The pairs' names, in the order of the P axis."""
        return [p["name"] for p in self.pairs]

    def __repr__(self):
        return f"Distances(distance shape {self.distance.shape}, {len(self.pairs)} pairs)"


class CbfRows(tuple):
    """``(A, b)``: the CBF rows ``A u >= b`` of every configuration (unpacks as a tuple).

    ``A`` ``(N, R, dof)``, ``b`` ``(N, R)`` (N absent for one configuration), R = P + the field
    rows + the joint-limit rows. Row ``p < P`` is pair p of ``distances.pairs``:
    ``∇_q D_p · u >= −η (D_p − δ)``, δ = ``margins["self"]`` for a self pair, else
    ``margins["obstacle"]``; then, with ``fields``, row ``P + r`` is the barrier's row r
    (:attr:`FieldBarrier.names`): ``∇_q h_r · u >= −η (h_r − δ_r)``; then per joint with a finite
    lower limit (joint order)
    ``u_i >= −η_q (q_i − q_min_i)``, then per joint with a finite upper limit
    ``−u_i >= −η_q (q_max_i − q_i)`` (continuous joints have neither). A q beyond a limit is
    accepted (as by :meth:`Robot.distances`): that limit's row then has b > 0, asking u to bring
    the joint back inside at rate η_q, as a CBF does outside its safe set.
    Also ``.distances`` (the :class:`Distances` they come from) and ``.state`` (for ``warm_start``).
    """

    def __new__(cls, A, b, distances: Distances):
        self = super().__new__(cls, (A, b))
        self.distances = distances
        return self

    @property
    def A(self) -> np.ndarray:
        return self[0]

    @property
    def b(self) -> np.ndarray:
        return self[1]

    @property
    def state(self):
        return self.distances.state


class FieldBarrier:
    """Kelvin fields as barriers (the semantics-aware distance h of kelvin-semantics-aware-distance.txt)
    on points fixed to the robot's links: one row per (field, control point), field-major, each
    keeping ``h(x(q)) >= δ`` of its field. Make one with :meth:`Robot.field_barrier`.

    ``fields``: the CBF scenarios' entries, ``{"name"?, "mesh": {"asset": NAME} | {"path": FILE},
    "lx" | "lx_fraction", "grading"?, "center"?, "far_radius"?, "feature_angle"?, "repair"?,
    "repair_options"?, "pose"?: {"position", "quaternion" [w, x, y, z]}, "sigma"?: as
    :meth:`distlab.kelvin.Field.set_sigma` takes it as a dict (``per_vertex`` in the file's vertex
    order, ``axis``, ``brushes``, ``constant``), "delta"?: δ (default 0)}``, prepared once through
    the disk cache (``cache_dir``; default the user's cache, as ``distlab serve``).
    ``control_points``: ``{"link", "point": [x, y, z] (link frame), "name"?}`` or ``{"link",
    "element"?: a collision element's name, "sample": COUNT}`` (points on the element surfaces).

    The rows use the paper's smoothed ∇h (continuous across cells, so u changes continuously);
    ``evaluate(q, gradient="cell")`` gives the derivative of the interpolated h instead, which is
    what finite differences of h see (they differ by O(l_x))."""

    def __init__(self, core):
        self._core = core

    def evaluate(self, q, gradient: str = "smoothed"):
        """``(h, grad)``: h ``(N, R)`` and ∇_q h ``(N, R, dof)`` (N absent for one configuration),
        rows as :attr:`names`. A control point inside an object (h undefined) raises
        :class:`distlab.errors.FieldUndefined` (a RuntimeError) naming it."""
        q = _q_array(q)
        h, g, status = self._core.evaluate(q, gradient)
        if (status != 0).any():
            n, r = np.argwhere(status != 0)[0]
            raise FieldUndefined(f"{self.names[r]}: h is undefined at configuration {n} (the point is inside the object)")
        return (h[0], g[0]) if q.ndim == 1 else (h, g)

    @property
    def names(self) -> list:
        """Row names ``"POINT/FIELD"``, field-major."""
        return self._core.names

    @property
    def margins(self) -> np.ndarray:
        """δ of every row."""
        return np.asarray(self._core.margins)

    @property
    def points(self) -> list:
        """The control points: ``{"name", "link", "point"}`` (link frame), sampled ones expanded."""
        return self._core.points


class Robot:
    """A robot from URDF: revolute, continuous, prismatic and fixed joints (and ``<mimic>``),
    collision elements ``<box>``, ``<cylinder>``, ``<sphere>`` and ``<mesh>`` (STL/OBJ/PLY/OFF,
    glTF/GLB or Collada DAE; its convex hull, ``scale`` honoured). Immutable."""

    def __init__(self, core: "_core.Robot"):
        self._core = core

    @classmethod
    def from_urdf(cls, path: Union[str, os.PathLike], package_dirs: Optional[Mapping[str, Any]] = None,
                  package_search_dirs: Sequence[Union[str, os.PathLike]] = (),
                  require_closed_meshes: bool = False) -> "Robot":
        """Reads a URDF file. Mesh filenames relative to the file's folder, absolute, ``file://``
        or ``package://NAME/rest``: read from ``package_dirs[NAME]/rest``, else from the first
        ``DIR/NAME/rest`` that exists for DIR in ``package_search_dirs`` (folders holding packages,
        as ROS_PACKAGE_PATH). A mesh that is not a closed surface gives its vertices' convex hull
        all the same, with a warning (``require_closed_meshes=True`` refuses it). What was accepted
        but may surprise is in :attr:`warnings`, each also issued as a ``UserWarning``. A bad
        file raises :class:`distlab.InvalidInput` (field ``"urdf"``) whose message names the URDF
        element; so does, before any XML parser reads it, a file nesting elements deeper than 64,
        with more than 64 attributes on an element, CDATA, a DOCTYPE or unquoted attribute
        values (an untrusted file cannot exhaust the stack or take seconds to parse). A file or a
        ``package_dirs`` folder that is not there raises InvalidInput naming it (``"urdf"``,
        ``"package_dirs['NAME']"``) with its absolute path; ``package_search_dirs`` may list folders
        that are not there (as ROS_PACKAGE_PATH)."""
        # The paths are the caller's own: the messages give them whole (the C++ reader, shared
        # with the service, names the file alone).
        file = os.path.abspath(os.fspath(path))
        if os.path.isdir(file):
            raise InvalidInput("urdf", f'"{file}" is a folder, not a URDF file')
        if not os.path.exists(file):
            raise InvalidInput("urdf", f'cannot read the robot file "{file}": no such file')
        dirs = {}
        for name, folder in (package_dirs or {}).items():
            if not isinstance(name, str):
                raise InvalidInputType("package_dirs", f"package names must be strings, got {type(name).__name__}")
            dirs[name] = os.path.abspath(os.fspath(folder))
            if not os.path.isdir(dirs[name]):
                raise InvalidInput(f"package_dirs[{name!r}]", f'"{dirs[name]}" is not a folder')
        search = [os.path.abspath(os.fspath(folder)) for folder in package_search_dirs]
        robot = cls(_core.Robot.from_file(file, dirs, search, bool(require_closed_meshes)))
        for message in robot.warnings:
            warnings.warn(f"{os.fspath(path)}: {message}", UserWarning, stacklevel=2)
        return robot

    @classmethod
    def load(cls, name: str) -> "Robot":
        """A built-in robot: ``assets/robots/NAME.urdf`` (``"panda"``, ``"ur5e"``), found as the
        CBF scenarios are ($DISTLAB_ASSETS, else the package's assets)."""
        return cls(_core.Robot.load(name))

    @property
    def name(self) -> str:
        return self._core.name

    @property
    def dof(self) -> int:
        return self._core.dof

    @property
    def joint_names(self) -> list:
        """The independent joints (not fixed, not mimic), in URDF file order: the order of q."""
        return self._core.joint_names

    @property
    def joint_types(self) -> list:
        """``"revolute"`` (continuous included) or ``"prismatic"`` per entry of q."""
        return self._core.joint_types

    @property
    def links(self) -> list:
        """Link names in URDF file order: the L axis of :meth:`fk`."""
        return self._core.links

    @property
    def ee_link(self) -> str:
        """The end-effector link (``<distlab:end_effector>``, else the last leaf link)."""
        return self._core.ee_link

    @property
    def q_min(self) -> np.ndarray:
        """Lower joint limits ``(dof,)``; −inf for continuous joints."""
        return self._core.q_min

    @property
    def q_max(self) -> np.ndarray:
        """Upper joint limits ``(dof,)``; +inf for continuous joints."""
        return self._core.q_max

    @property
    def velocity_max(self) -> np.ndarray:
        """``<limit velocity>`` per joint ``(dof,)``; +inf where the URDF gives none."""
        return self._core.velocity_max

    @property
    def warnings(self) -> list:
        """What the URDF reader accepted but may surprise: an open collision mesh (its hull is
        used), a joint without limits (taken as unbounded)."""
        return self._core.warnings

    @property
    def collision_elements(self) -> list:
        """The collision elements (the pairs' order): dicts ``name``, ``link``, ``element`` (index
        among the link's ``<collision>``), ``type`` (``box``, ``cylinder``, ``sphere``,
        ``capsule``, ``convex_hull`` for a mesh), ``mesh`` (the filename, or None) and ``pose``
        (in the link frame, ``[x, y, z, qw, qx, qy, qz]``)."""
        return self._core.collision_elements

    def fk(self, q) -> np.ndarray:
        """World poses of every link, ``[x, y, z, qw, qx, qy, qz]``: ``(N, L, 7)`` for q
        ``(N, dof)``, ``(L, 7)`` for q ``(dof,)``; links in :attr:`links` order."""
        q = _q_array(q)
        out = self._core.fk(q)
        return out[0] if q.ndim == 1 else out

    def jacobian(self, q, link: Optional[str] = None, point: Optional[Sequence[float]] = None) -> np.ndarray:
        """The geometric Jacobian ``[v; ω]`` (world frame) of the point ``point`` (link frame,
        default its origin) fixed to ``link`` (default :attr:`ee_link`): ``(N, 6, dof)`` for q
        ``(N, dof)``, ``(6, dof)`` for q ``(dof,)``."""
        q = _q_array(q)
        out = self._core.jacobian(q, link, None if point is None else np.asarray(point, dtype=np.float64))
        return out[0] if q.ndim == 1 else out

    def distances(self, q, obstacles: Sequence[Mapping[str, Any]] = (), metric: str = "gap", pairs: PairsArg = "obstacles",
                  params: Any = None, threads: int = 0, warm_start: Any = None, tracking: bool = True) -> Distances:
        """Every pair's distance, witnesses and dD/dq at each configuration (see :class:`Distances`).

        ``metric``: ``"gap"`` (the GAP distance D = sqrt(2Λ)) or ``"euclidean"`` (FCL).
        ``pairs``: ``"obstacles"`` (every collision element with every obstacle), ``"self"``
        (elements of links at least two moving joints apart), ``"both"``, or a dict
        ``{"obstacles": bool, "self": bool, "allow": [[link_a, link_b], ...], "deny": [...]}``
        (allow adds, deny removes self pairs of those links; both need ``"self": True``).
        ``params``: the GAP parameters (a dict as ``distlab gap``'s ``"params"``, or a
        :class:`distlab.gap.Params`); ``validate`` (default on) checks Property 2 of every body
        once per model (a failing obstacle raises InvalidInput ``"obstacles[i]"``, a failing
        collision element ``"urdf"`` or, for a built-in robot, ``"name"``). A collision element small
        against ``h`` (a few millimetres: an IMU's box, a placeholder sphere) that fails
        Property 2 takes its own, smaller h where it holds, with a ``UserWarning`` naming it and
        that h; its distances are then sharper than the other elements'. An element large
        against ``h`` (bounding radius 3 h or more) that fails takes its own, smaller eps
        instead, with a ``UserWarning`` as well.
        ``threads``: 0 for every core; a batch is split into contiguous runs, one per thread.
        ``tracking`` (GAP): each configuration continues from the solution of the one before in
        its run (gap_distance_tracked; the same answers within the solver's tolerance, fewer
        Newton steps along a trajectory); False solves each one cold. ``warm_start``: the
        previous call's result (or its ``state``) for the first configuration; a state of
        another robot, obstacle set, pair selection, metric or params raises InvalidInput
        (``"warm_start"``). The same obstacles at other poses are the same set: a moving
        obstacle keeps the model built for it (its GAP bodies, validated once), and its pairs
        continue from the state. Move it by its ``"pose"``, its shape (a hull's ``"points"``)
        given once in its own frame: changed points are another obstacle.

        Runs without the GIL; Ctrl-C stops a long batch (KeyboardInterrupt)."""
        q = _q_array(q)
        out = self._core.distances(q, _obstacles(obstacles), metric, pairs, _params(params), _threads(threads),
                                   _state(warm_start), bool(tracking))
        return Distances(out, q.ndim == 1)

    def cbf_rows(self, q, obstacles: Sequence[Mapping[str, Any]] = (), metric: str = "gap", pairs: PairsArg = "both",
                 margins: Optional[Mapping[str, float]] = None, eta: float = 0.5, eta_joint: float = 0.5,
                 params: Any = None, threads: int = 0, warm_start: Any = None, tracking: bool = True,
                 fields: Optional[FieldBarrier] = None) -> CbfRows:
        """The CBF rows ``A u >= b`` (u the joint velocity) of the corridor controller (paper eq. 7)
        for your own QP, from the same distances (see :class:`CbfRows`). ``margins``:
        ``{"obstacle": δ_obs, "self": δ_self}`` (either may be left out); default the scenario's
        for the metric (gap 0.002 / 0.0001, euclidean 0.03 / 0.01). ``fields``: a
        :class:`FieldBarrier` of this robot, whose rows come after the pairs' (the built-in
        controller's order). The other arguments as :meth:`distances`. Overlapping pairs, whose rows
        no u satisfies, are named in a ``UserWarning``."""
        q = _q_array(q)
        if fields is not None and not isinstance(fields, FieldBarrier):
            raise InvalidInputType("fields", "fields must be a FieldBarrier (Robot.field_barrier)")
        A, b, out = self._core.cbf_rows(q, _obstacles(obstacles), metric, pairs,
                                        None if margins is None else dict(margins), float(eta), float(eta_joint),
                                        _params(params), _threads(threads), _state(warm_start), bool(tracking),
                                        None if fields is None else fields._core)
        single = q.ndim == 1
        rows = CbfRows(A[0] if single else A, b[0] if single else b, Distances(out, single))
        overlap = np.asarray(rows.distances.overlap)
        overlapping = np.flatnonzero(overlap if single else overlap.any(axis=0))
        if overlapping.size:
            # Their rows 0 · u >= η δ hold for no u: the QP is infeasible. A pair of a real
            # description that always overlaps (a gripper's linkage) is to be denied.
            names = [rows.distances.names[i] for i in overlapping[:4]]
            more = f" and {overlapping.size - 4} more" if overlapping.size > 4 else ""
            warnings.warn(f"cbf_rows: {', '.join(names)}{more} overlap, so their rows 0 · u >= eta · margin hold for no u; "
                          "a self pair that always overlaps is left out by pairs={'self': True, 'deny': [[link_a, link_b]]}",
                          UserWarning, stacklevel=2)
        return rows

    def field_barrier(self, fields: Sequence[Mapping[str, Any]], control_points: Sequence[Mapping[str, Any]],
                      cache_dir: Optional[Union[str, os.PathLike]] = None) -> FieldBarrier:
        """Kelvin fields as barriers on this robot's control points (see :class:`FieldBarrier`):
        prepares every field (seconds the first time, then from the cache). Bad input raises
        :class:`distlab.InvalidInput` naming the field (``"fields[0].lx"``,
        ``"control_points[2].link"``)."""
        return FieldBarrier(_core.FieldBarrier(self._core, [dict(f) for f in fields], [dict(c) for c in control_points],
                                               None if cache_dir is None else os.fspath(cache_dir)))

    def __repr__(self):
        return f"Robot({self.name!r}, dof={self.dof}, {len(self.links)} links)"
