"""The semantics-aware distance h(x) of an object by the Kelvin transformation.

Prepare once (σ-independent: inversion, tetrahedral mesh, factorization), then set σ on the
surface and query h and ∇h, extract or export iso-surfaces of h."""

from __future__ import annotations

import os
from typing import Any, Callable, Dict, List, Mapping, Optional, Sequence, Tuple, Union

import numpy as np

from . import _core, executable
from . import batch as _batch
from .errors import InvalidInput

__all__ = ["solve", "Field", "prepare_many", "INSIDE", "NONPOSITIVE"]

Mesh = Union[str, os.PathLike, Tuple[Any, Any]]

#: status codes of :meth:`Field.query` (0: ok)
INSIDE = 1
NONPOSITIVE = 2


def _mesh_worker() -> str:
    # The distlab program beside this package meshes mesh_threads > 1 in a child process, as the
    # CLI does: CGAL 5.5's parallel refinement crashes its process now and then. "": none there.
    exe = executable()
    return exe if os.access(exe, os.X_OK) else ""


def solve(request: Mapping[str, Any], progress: Optional[Callable[[str, float], Any]] = None) -> dict:
    """Runs a ``distlab kelvin`` request (``{"mesh", "lx", "sigma", "query", "isosurfaces", ...}``)
    and returns its response as a dict (numeric arrays as numpy arrays; ``null`` h as NaN): the
    CLI's numbers, bit for bit. ``progress(stage, fraction)`` as for :meth:`Field.prepare`."""
    return _core.kelvin_solve(dict(request), progress, _mesh_worker())


class Field:
    """A prepared object. Make one with :meth:`prepare`."""

    def __init__(self, core):
        self._core = core

    @classmethod
    def prepare(
        cls,
        mesh: Union[str, os.PathLike, Tuple[Any, Any]],
        lx: float,
        center: Optional[Sequence[float]] = None,
        far_radius: Optional[float] = None,
        grading: Optional[float] = None,
        feature_angle: Optional[float] = None,
        max_vertices: Optional[int] = None,
        cache_dir: Optional[Union[str, os.PathLike]] = None,
        progress: Optional[Callable[[str, float], Any]] = None,
        *,
        cache_budget: Optional[int] = None,
        unit: Optional[str] = None,
        scale: Optional[float] = None,
        components: Optional[str] = None,
        simplify: Optional[int] = None,
        repair: Optional[str] = None,
        repair_options: Optional[dict] = None,
        mesh_threads: Optional[int] = None,
    ) -> "Field":
        """Prepares ``mesh``: a file path (STL, OBJ, PLY, GLB, OFF) or ``(vertices (n, 3), faces
        (m, 3))`` arrays of a closed, oriented surface, with exterior element size ``lx`` (metres).
        ``center``: inversion centre (default a deep interior point); ``far_radius``,
        ``grading`` (0: the paper's sizing, eq. 23; > 0: graded, fewer vertices; None: chosen per
        object and ``lx``, reported as ``stats()["grading"]``), ``feature_angle``,
        ``max_vertices``: as in the CLI request. ``cache_dir``: saves the
        prepared field there (by content) and loads it on the next call with the same input: the
        field store (:mod:`distlab.cache`), which processes and machines may share; while one
        prepares a field, the others asking for it wait (progress stage ``"wait"``) and load it
        (``stats["t_wait"]``: seconds waited). ``cache_budget``: bytes the store's entries may
        take; after writing, the least recently used ones are evicted down to it.
        ``progress(stage, fraction)`` is called as work advances; Ctrl-C (KeyboardInterrupt), or an
        exception raised by ``progress``, cancels the preparation cleanly and propagates. σ starts
        at 0 everywhere.

        As the service's objects: ``unit`` ("m", "cm", "mm", "in") or ``scale`` (metres per unit
        of the mesh); ``components`` "all" (one field around every piece) or "largest" (the piece
        enclosing the largest volume); ``simplify`` a face count to simplify to (edge collapse,
        before the repair); ``repair`` "fix" or "wrap" with ``repair_options`` (fix:
        max_hole_edges; wrap: alpha, offset in metres), bounded by the service's default limits.
        Their reports are in ``stats()`` ("components", "simplify", "repair"). With any of these
        the field is prepared on the reshaped surface, and ``set_sigma(per_vertex=...)`` takes one
        value per vertex of ``surface`` (that surface's own).

        ``mesh_threads``: None, 0 or 1 meshes on one thread, the same mesh bit for bit on every
        run; n > 1 (opt-in) meshes in parallel on n threads: faster, the mesh (and the field
        within its accuracy) differs from run to run. As in the CLI and the service, it runs in a
        child process, the ``distlab`` program beside this package (:func:`distlab.executable`),
        because CGAL 5.5's parallel refinement crashes its process in about 1 of 1,000 small
        meshings: a crashed child is run once more, then the mesh is made on one thread, and
        ``stats["warnings"]`` says so (``stats["mesh_threads"]``: the threads it was made on).
        Without that program it runs in this process, which such a crash ends."""
        options = {"lx": lx, "center": center, "far_radius": far_radius, "grading": grading,
                   "feature_angle": feature_angle,
                   "max_vertices": max_vertices, "unit": unit, "scale": scale, "components": components,
                   "simplify": None if simplify is None else {"faces": simplify},
                   "repair": repair, "repair_options": repair_options, "cache_budget": cache_budget,
                   "mesh_threads": mesh_threads}
        cache = None if cache_dir is None else os.fspath(cache_dir)
        if isinstance(mesh, (str, os.PathLike)):
            core = _core.KelvinField.prepare(None, None, os.fspath(mesh), options, cache, progress, _mesh_worker())
        else:
            vertices, faces = mesh
            core = _core.KelvinField.prepare(np.asarray(vertices, dtype=np.float64), np.asarray(faces), None,
                                             options, cache, progress, _mesh_worker())
        return cls(core)

    def set_sigma(self, per_vertex=None, *, constant: float = 0.0, axis=None, brushes=None,
                  gradients: bool = True) -> None:
        """Sets σ on the surface: the sum of ``per_vertex`` (one value per vertex of the input
        mesh, in the file's vertex order after identical positions are welded, linear over faces),
        ``constant``, ``axis`` terms (eq. 24: dicts ``{"axis", "d0", "sigma_nom", "origin",
        "width"}``) and ``brushes`` (``{"center", "radius", "value", "falloff", "mode"}``, applied
        in order; ``"mode": "towards"`` moves σ towards the value instead of adding it). Then solves
        for the field (and its vertex gradients unless ``gradients`` is False)."""
        spec: dict = {"constant": constant}
        if per_vertex is not None:
            spec["per_vertex"] = np.asarray(per_vertex, dtype=np.float64)
        if axis is not None:
            spec["axis"] = axis
        if brushes is not None:
            spec["brushes"] = brushes
        self._core.set_sigma(spec, gradients)

    def build_boundary_response(self, max_megabytes: float = 512,
                                progress: Optional[Callable[[str, float], Any]] = None) -> bool:
        """Precomputes the change of the field per unit change of each boundary value
        (n_interior × n_boundary doubles, ``stats["response_mb"]``), if that takes at most
        ``max_megabytes``; returns whether it did. Brush strokes added to σ (``set_sigma`` with the
        previous brushes plus new ones) then cost about 0.2× a full solve instead of 0.8× on a
        26k-vertex field, with the same result to rounding. ``progress`` and cancelling as in
        :meth:`prepare`."""
        return self._core.build_boundary_response(max_megabytes, progress)

    def query(self, points, hints: bool = True) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """h (N,), ∇h (N, 3) and status (N,) (0 ok, INSIDE, NONPOSITIVE; h and ∇h NaN there; a
        point within rounding of the input surface, 1e-12·max(1, |x|) m, is answered, not INSIDE) at
        ``points`` (N, 3). With ``hints`` each point's search starts at the previous point's cell
        (fast for coherent orders such as lines and grids); the answers are the same either way."""
        p = np.ascontiguousarray(np.asarray(points, dtype=np.float64).reshape(-1, 3))
        return self._core.query(p, hints)

    def isosurface(self, level: float) -> Tuple[np.ndarray, np.ndarray]:
        """The closed surface {h = level}: vertices (n, 3) float64, faces (m, 3) int32."""
        return self._core.isosurface(float(level))

    def export(self, path: Union[str, os.PathLike], level: float, format: Optional[str] = None) -> dict:
        """Writes the iso-surface {h = level} to ``path`` (``format`` stl, obj, ply or glb; default
        from the file's extension) and returns its check: ``closed``, ``manifold``,
        ``components``, ``volume`` and the defect counts, taken on the surface welded at float32.
        A surface that is not a closed 2-manifold is not written (``distlab.InvalidInput`` on
        ``level``). At σ's smallest value on the surface it is the object's surface as meshed (the
        field's boundary facets, within the mesher's l_x-scale approximation of the input, not the
        input's triangles: an input vertex can lie just inside it, and ``query`` still answers there);
        every other level is extracted at level − 1e-5 (so no vertex of the mesh lies exactly on
        it)."""
        path = os.fspath(path)
        fmt = format or os.path.splitext(path)[1].lstrip(".").lower()
        return self._core.export(path, float(level), fmt)

    @property
    def stats(self) -> dict:
        """Sizes and timings: n_verts, n_tets, size_mb, t_mesh, t_build, t_decomp, t_solve, grading,
        response_mb (0 until :meth:`build_boundary_response`), cache_hit, warnings; and of the last
        ``set_sigma``: linear_boundary (boundary values a stroke changed, solved by linearity; -1
        for a full solve) and linear_by_response (that change applied by the boundary response)."""
        return self._core.stats()

    @property
    def surface(self) -> Tuple[np.ndarray, np.ndarray]:
        """The validated input surface (vertices, faces), in the order σ's per_vertex follows."""
        return self._core.surface()

    @property
    def center(self) -> np.ndarray:
        """The inversion centre."""
        return self._core.centre()


def prepare_many(meshes: Sequence[Mesh], lx: float, *, cache_dir: Union[str, os.PathLike],
                 progress: Optional[Callable[[str, float], Any]] = None, client: Any = None, wait: bool = True,
                 **options: Any) -> Any:
    """Prepares every mesh of ``meshes`` (each a path or ``(vertices, faces)``, as
    :meth:`Field.prepare` takes them) with ``lx`` and the same ``options`` (``center``,
    ``grading``, ``unit``, ``repair``, ... as :meth:`Field.prepare`'s) into ``cache_dir``, the
    cache directory :meth:`Field.prepare` then loads each field from. Returns each field's
    :attr:`Field.stats` (``cache_hit`` for one that was there already), in the order of
    ``meshes``. ``progress(stage, fraction)``: stage ``"K of N fields prepared"``, fraction the
    mean of the preparations' progress through their stages; Ctrl-C (KeyboardInterrupt), or an
    exception raised by ``progress``, cancels the preparations and propagates.

    Without ``client`` the meshes are prepared one after another in this process. ``client``: a
    ``dask.distributed.Client`` (:mod:`distlab.batch`; dask is imported only then): one task per
    mesh on the workers, each preparing through ``cache_dir`` exactly as :meth:`Field.prepare`
    does here (the same field, bit for bit), so ``cache_dir`` and the mesh files must be the same
    paths on the workers (one machine, or a shared filesystem); ``(vertices, faces)`` travel with
    their tasks as numpy arrays. With ``wait=False`` the call returns the
    :class:`distlab.batch.Batch` at once (``progress()``, ``wait(progress)``, ``cancel()``,
    ``result()``)."""
    cache = os.path.abspath(os.fspath(cache_dir))
    meshes = [os.path.abspath(os.fspath(m)) if isinstance(m, (str, os.PathLike))
              else (np.asarray(m[0], dtype=np.float64), np.asarray(m[1])) for m in meshes]
    report = _batch.count_report("fields prepared")
    if client is None:
        if not wait:
            raise ValueError("wait=False needs a client")
        finished = [False] * len(meshes)
        partial = [0.0] * len(meshes)
        out: List[Dict[str, Any]] = []

        def one(i: int):
            def task_progress(fraction: float) -> None:
                partial[i] = max(partial[i], fraction)
                if progress is not None:
                    progress(*report(finished, partial))
            return task_progress

        for i, mesh in enumerate(meshes):
            try:
                out.append(_prepare_task(mesh, lx, cache, options, one(i)))
            except InvalidInput as e:
                raise _mesh_error(i, mesh, e) from None
            finished[i] = True
            if progress is not None:
                progress(*report(finished, partial))
        return out
    tasks = [(mesh, lx, cache, options) for mesh in meshes]
    b = _batch.Batch(client, "kelvin-prepare", _prepare_task, tasks, list, report,
                     lambda i, e: _mesh_error(i, meshes[i], e))
    return b.wait(progress) if wait else b


def _mesh_error(i: int, mesh: Mesh, error: BaseException) -> BaseException:
    """An error of one mesh's preparation names the mesh in the batch (meshes[i] and its path):
    with hundreds of meshes, "path: no such file" does not say which."""
    if not isinstance(error, InvalidInput):
        return error
    what = f"meshes[{i}]" + (f" ({mesh})" if isinstance(mesh, str) else "")
    mesh_field = error.field in ("", "path", "mesh") or error.field.startswith(("vertices", "faces", "mesh."))
    return type(error)(f"meshes[{i}]" if mesh_field else error.field, f"{what}: {error.message}")


def _prepare_task(mesh: Mesh, lx: float, cache_dir: str, options: Mapping[str, Any],
                  report: Callable[[float], None]) -> Dict[str, Any]:
    """One preparation of prepare_many (a task of its client=): the field's stats. Its progress
    is the preparation's overall fraction, its stages weighed by their typical seconds for the
    sizing asked (the service's kelvin::StageProgress; meshing takes most of it, not a sixth)."""
    grading = options.get("grading")
    stages = _core.KelvinStageProgress(**({} if grading is None else {"grading": float(grading)}))

    def progress(stage: str, fraction: float) -> None:
        report(stages.report(stage, fraction))

    return Field.prepare(mesh, lx, cache_dir=cache_dir, progress=progress, **options).stats
