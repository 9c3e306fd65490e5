"""A client for ``distlab serve``: sessions, GAP, Kelvin objects, CBF rollouts and sweeps.

Responses come back as dicts whose numeric arrays are numpy arrays; mesh frames (msgpack) are
decoded into numpy arrays that view the received bytes (no copy). Errors of the service
(``{"error": {"code", "message", "field"}}``, 4xx) raise :class:`ServiceError`, a
:class:`distlab.InvalidInput` naming the field."""

from __future__ import annotations

import json
import os
import time
import warnings
from typing import TYPE_CHECKING, Any, Callable, Dict, Iterator, List, Mapping, Optional, Tuple, Union
from urllib.parse import quote, urlsplit, urlunsplit

import msgpack
import numpy as np
import requests
import websocket

from .errors import InvalidInput, InvalidInputType

if TYPE_CHECKING:
    from .scene import Scene

__all__ = ["Client", "CbfSweep", "KelvinObject", "Live", "ServiceError", "decode_mesh_frame"]


class ServiceError(InvalidInput):
    """An error answer of the service: ``status`` (HTTP), ``code`` (e.g. ``invalid_input``,
    ``time_limit``), ``field`` and ``message``."""

    def __init__(self, status: int, code: str, field: str, message: str):
        super().__init__(field, f"{message} (HTTP {status} {code})")
        self.status, self.code = status, code


def _arrays(x):
    """JSON values with numeric lists as numpy arrays (float64, or int64 for integers; None as NaN),
    as distlab.gap.solve returns them."""
    if isinstance(x, dict):
        return {k: _arrays(v) for k, v in x.items()}
    if isinstance(x, list):
        if x and all(isinstance(v, bool) for v in x):
            return np.array(x, dtype=bool)
        try:
            flat = np.array(x, dtype=object)
        except ValueError:
            flat = None
        if flat is not None and flat.size and flat.dtype == object and all(
                v is None or (isinstance(v, (int, float)) and not isinstance(v, bool)) for v in flat.ravel()):
            ints = all(isinstance(v, int) for v in flat.ravel())
            return np.array([[np.nan if v is None else v] for v in flat.ravel()],
                            dtype=np.int64 if ints else np.float64).reshape(flat.shape)
        return [_arrays(v) for v in x]
    return x


# The arrays of mesh frames (frames.hpp): little-endian float32 / uint32, and their row widths.
_FRAME_ARRAYS = {"positions": ("<f4", 3), "indices": ("<u4", 3), "scalars": ("<f4", 1), "sigma": ("<f4", 1),
                 "colors": ("<f4", 3)}
_BIN_HEADER = {0xC4: 2, 0xC5: 3, 0xC6: 5}  # msgpack bin 8/16/32: type byte + length bytes


def decode_mesh_frame(data: bytes) -> dict:
    """A msgpack mesh frame (a WebSocket binary message or a REST download): ``positions`` (n, 3)
    float32, ``indices`` (m, 3) uint32 (a lines scene item's: (m, 2)), ``scalars`` (n,) and ``colors``
    (n, 3) float32 when present, as read-only numpy
    views of ``data`` itself (no copy: their offsets are found by walking the map), the other keys
    as sent."""
    unpacker = msgpack.Unpacker(raw=False, max_buffer_size=max(len(data), 1))
    unpacker.feed(data)
    out = {}
    for _ in range(unpacker.read_map_header()):
        key = unpacker.unpack()
        start = unpacker.tell()
        header = _BIN_HEADER.get(data[start]) if key in _FRAME_ARRAYS else None
        if header is None:
            out[key] = unpacker.unpack()
            continue
        unpacker.skip()
        dtype = _FRAME_ARRAYS[key][0]
        count = (unpacker.tell() - start - header) // np.dtype(dtype).itemsize
        out[key] = np.frombuffer(data, dtype=dtype, count=count, offset=start + header)
    for key, (_, width) in _FRAME_ARRAYS.items():
        if key == "indices" and out.get("kind") == "lines":
            width = 2  # scene items' line segments
        if isinstance(out.get(key), np.ndarray) and width > 1:
            out[key] = out[key].reshape(-1, width)
    return out


class Client:
    """The service at ``url`` (e.g. ``http://127.0.0.1:8080``) with a new session (or ``session``).

    Behind replicas (docker/replicas), cookies keep the session on its replica. When the session
    is gone (its replica stopped, or it expired), the next request re-creates it with ``recover``
    (the default): a new session, this client's uploads sent again and its Kelvin objects made
    again with their σ (their fields come from the shared store, not prepared again); the
    ``KelvinObject`` handles stay valid. A RuntimeWarning says so and ``recoveries`` counts it.
    Jobs of the lost session (rollouts, sweeps) and scene items are not re-created. To re-send
    uploads the client keeps their bytes until :meth:`delete_upload`."""

    def __init__(self, url: str, session: Optional[str] = None, timeout: float = 60.0, *, recover: bool = True):
        self.url = url.rstrip("/")
        self.timeout = timeout
        self.recover = recover
        self.recoveries = 0
        self.http = requests.Session()
        self._objects: List["KelvinObject"] = []  # what a new session makes again
        # upload id -> (file bytes, query), or (None, {"digest"}) for one reused by its digest
        self._uploads: Dict[str, Tuple[Optional[bytes], dict]] = {}
        self._renamed: Dict[str, str] = {}  # upload and job ids of a lost session -> their successors
        self._recovering = False
        self.session = session or self._send("POST", "/api/session")["session"]
        self.http.headers["X-Distlab-Session"] = self.session

    # -- plumbing -------------------------------------------------------------------------------

    def _request(self, method: str, path: Union[str, Callable[[], str]], *, raw: bool = False, **kwargs):
        """A request of this session; ``path`` may be a function (an object's path after a recovery)."""
        try:
            return self._send(method, path() if callable(path) else path, raw=raw, **kwargs)
        except ServiceError as e:
            if e.code != "unknown_session" or not self.recover or self._recovering:
                raise
        self._recover()
        return self._send(method, path() if callable(path) else path, raw=raw, **kwargs)

    def _recover(self) -> None:
        """A new session with this client's uploads and Kelvin objects (see the class)."""
        self._recovering = True
        try:
            lost = self.session
            for cookie in [c for c in self.http.cookies if c.name == "distlab_session"]:
                self.http.cookies.clear(cookie.domain, cookie.path, cookie.name)
            del self.http.headers["X-Distlab-Session"]
            self.session = self._send("POST", "/api/session")["session"]
            self.http.headers["X-Distlab-Session"] = self.session
            for old, (data, query) in list(self._uploads.items()):
                if data is None:  # reused by its digest: the server must hold it still
                    self._renamed[old] = self._send("POST", "/api/kelvin/uploads/reuse", json=query)["upload"]
                else:
                    self._renamed[old] = self._send("POST", "/api/kelvin/uploads", params=query, data=data)["upload"]
                self._uploads[self._renamed[old]] = self._uploads.pop(old)
            for obj in self._objects:
                body = dict(obj._body)
                if "upload" in body:
                    body["upload"] = self._current(body["upload"])
                answer = self._send("POST", "/api/kelvin/objects", json=body)
                obj.id, self._renamed[obj.job] = answer["object"]["id"], answer["job"]["id"]
                obj.job, obj._body = answer["job"]["id"], body
                self.wait(obj.job)
                if obj._sigma is not None:
                    self._send("PUT", obj._path("/sigma"), json=obj._sigma)
            self.recoveries += 1
            warnings.warn(f"distlab session {lost} was lost (its replica stopped or it expired): re-created as "
                          f"{self.session} with {len(self._uploads)} upload(s) and {len(self._objects)} object(s)",
                          RuntimeWarning, stacklevel=3)
        finally:
            self._recovering = False

    def _current(self, name: str) -> str:
        """An upload's or job's id in the current session (ids of lost sessions are renamed)."""
        while name in self._renamed:
            name = self._renamed[name]
        return name

    def _send(self, method: str, path: str, *, raw: bool = False, **kwargs):
        r = self.http.request(method, self.url + path, timeout=self.timeout, **kwargs)
        if r.status_code >= 400:
            try:
                e = r.json()["error"]
            except (ValueError, KeyError, TypeError):
                r.raise_for_status()
            if r.status_code >= 500:
                raise RuntimeError(f"{e.get('code')}: {e.get('message')} (HTTP {r.status_code})")
            raise ServiceError(r.status_code, e.get("code", ""), e.get("field", ""), e.get("message", ""))
        if raw:
            return r.content
        return r.json() if r.content else None

    def _ws(self) -> websocket.WebSocket:
        parts = urlsplit(self.url)
        scheme = "wss" if parts.scheme == "https" else "ws"
        # The cookies go along: behind replicas, they choose the session's replica.
        cookies = "; ".join(f"{c.name}={c.value}" for c in self.http.cookies)
        ws = websocket.create_connection(urlunsplit((scheme, parts.netloc, "/ws", f"session={self.session}", "")),
                                         timeout=self.timeout, cookie=cookies or None)
        return ws

    def health(self) -> dict:
        """GET /api/health."""
        return self._request("GET", "/api/health")

    def limits(self) -> dict:
        """The service's limits (GET /api/limits)."""
        return self._request("GET", "/api/limits")

    def page_url(self, view: str = "gap") -> str:
        """The front end's page of a view in this session: it shows this client's scene items."""
        return f"{self.url}/?session={self.session}#/{view}"

    @property
    def scene(self) -> "Scene":
        """Your own meshes, points, lines and frames in the session's pages (:class:`distlab.scene.Scene`)."""
        from .scene import Scene

        return Scene(self)

    def record(self, path: Union[str, os.PathLike], *, seconds: Optional[float] = None, frames: Optional[int] = None,
               view: str = "gap", fps: float = 30, width: int = 960, height: int = 600, timeout: float = 120) -> dict:
        """Records a view of this session (its scene items included) in headless chromium: a WebM
        video when ``path`` ends in .webm, else PNG frames (``path`` a directory: frame_0000.png ...;
        a pattern such as ``out/f_%03d.png``; or ``out.png``: out_0000.png ...). Give ``seconds`` or
        ``frames`` (bounded by max_record_seconds, max_record_frames, max_record_fps); the page's
        window is ``width`` x ``height``. Returns the recording (``files``, ``camera``: the clip
        matrix the page drew with; ``recorded``: the frames the file holds and the seconds they
        span, longer than asked when the page draws slower than ``fps``). Ctrl-C or ``timeout`` (seconds beyond its length) stops it."""
        from .scene import record

        return record(self, path, seconds=seconds, frames=frames, view=view, fps=fps, width=width, height=height,
                      timeout=timeout)

    def close(self) -> None:
        """Ends the session (its jobs are cancelled); one already gone is not re-created."""
        try:
            self._send("DELETE", "/api/session")
        except ServiceError as e:
            if e.code != "unknown_session":
                raise

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    # -- GAP ------------------------------------------------------------------------------------

    def gap_distance(self, request: Mapping[str, Any]) -> dict:
        """POST /api/gap/distance with the CLI's request (see distlab.gap.solve)."""
        return _arrays(self._request("POST", "/api/gap/distance", json=_plain(request)))

    # -- jobs -----------------------------------------------------------------------------------

    def job(self, job_id: str) -> dict:
        """A job's state (GET /api/jobs/ID): state, stage, fraction, error."""
        return self._request("GET", lambda: f"/api/jobs/{self._current(job_id)}")

    def cancel(self, job_id: str) -> None:
        """Asks the service to cancel a job (it stops at its next checkpoint)."""
        self._request("POST", lambda: f"/api/jobs/{self._current(job_id)}/cancel")

    def wait(self, job_id: str, progress: Optional[Callable[[str, float], Any]] = None,
             poll: float = 0.05, timeout: float = 3600) -> dict:
        """Waits for a job, calling ``progress(stage, fraction)`` as it advances; Ctrl-C cancels
        the job on the server and re-raises. Raises ServiceError if the job failed."""
        end = time.monotonic() + timeout
        try:
            while True:
                job = self.job(job_id)
                if progress is not None and "stage" in job:
                    progress(job["stage"], job.get("fraction", 0.0))
                if job["state"] in ("succeeded", "failed", "cancelled"):
                    break
                if time.monotonic() > end:
                    raise TimeoutError(f"job {job_id} still {job['state']} after {timeout} s")
                time.sleep(poll)
        except KeyboardInterrupt:
            self.cancel(job_id)
            raise
        if job["state"] != "succeeded":
            e = job.get("error") or {}
            raise ServiceError(422, e.get("code", job["state"]), e.get("field", ""), e.get("message", job["state"]))
        return job

    # -- Kelvin ---------------------------------------------------------------------------------

    def upload(self, mesh: Union[str, os.PathLike, bytes], format: Optional[str] = None, *,
               unit: Optional[str] = None, scale: Optional[float] = None, digest: Optional[str] = None,
               info: bool = False) -> Any:
        """Uploads a mesh file (path or bytes; ``format`` from the extension by default) in its
        ``unit`` ("m", "cm", "mm", "in") or ``scale`` (metres per file unit); its id, or with
        ``info`` the whole answer (``digest``, ``bounding_box``, ``lx_range``, ``lx_fraction_range``,
        ...). With ``digest`` (the mesh a link or :meth:`reuse_upload` names) a file whose mesh has
        another digest is refused: ServiceError 422 ``different_mesh``, field ``body``."""
        if unit is not None and scale is not None:
            raise ValueError("give unit or scale, not both")
        if not isinstance(mesh, (bytes, bytearray)):
            format = format or os.path.splitext(os.fspath(mesh))[1].lstrip(".").lower()
            with open(mesh, "rb") as f:
                mesh = f.read()
        params: Dict[str, Any] = {"format": format}
        if unit is not None:
            params["unit"] = unit
        if scale is not None:
            params["scale"] = repr(float(scale))
        if digest is not None:
            params["digest"] = _digest(digest)
        answer = self._request("POST", "/api/kelvin/uploads", params=params, data=bytes(mesh))
        if self.recover:
            self._uploads[answer["upload"]] = (bytes(mesh), params)
        return answer if info else answer["upload"]

    def delete_upload(self, upload: str) -> None:
        """Forgets an upload: its triangles leave this client's share of the server's
        (``max_held_triangles_per_address``); objects made from it keep their own."""
        self._request("DELETE", lambda: self._upload_path(upload))
        self._uploads.pop(self._current(upload), None)

    def reuse_upload(self, digest: str, *, info: bool = False) -> Any:
        """A mesh this server already holds (an upload of any session, while one holds it), named
        by its ``digest`` (SHA-256, 64 lower-case hex digits: an upload's ``info["digest"]``, an
        object's ``surface_digest``, a shared link's), made an upload of this session without
        sending the file (POST /api/kelvin/uploads/reuse); its id, or with ``info`` the whole
        answer (as :meth:`upload`'s, with ``reused`` True). Nothing else of the session that
        uploaded it is given. A digest the server does not hold (no session holds it any more, or
        another server) raises ServiceError 404 ``upload_not_held``, field ``digest``: upload the
        file again, with ``upload(path, digest=digest)`` to have it checked."""
        body = {"digest": _digest(digest)}
        answer = self._request("POST", "/api/kelvin/uploads/reuse", json=body)
        if self.recover:
            self._uploads[answer["upload"]] = (None, body)
        return answer if info else answer["upload"]

    def upload_surface(self, upload: str) -> dict:
        """An upload's mesh as the server read it, to look at before preparing it (GET
        /api/kelvin/uploads/ID/surface): ``positions`` (n, 3) float32, the file's vertices in its
        order, in metres (after the unit or scale); ``indices`` (m, 3) uint32, its triangles in the
        file's face order (a polygon's triangles in order); ``digest``, ``upload``. The numbering
        is the one :meth:`upload_defects` and refusals use. An id not of this session raises
        ServiceError 404 naming field ``id``."""
        return decode_mesh_frame(self._request("GET", lambda: self._upload_path(upload, "/surface"), raw=True))

    def upload_defects(self, upload: str, *, geometry: bool = True) -> dict:
        """Where an upload is not a closed 2-manifold (GET /api/kelvin/uploads/ID/defects), as the
        preparation sees it, in the numbering of :meth:`upload_surface`: ``counts`` (whole
        counts: boundary_edges, non_manifold_edges, non_manifold_vertices, degenerate_faces,
        self_intersections, components), and the lists as int64 arrays, each at most ``max_items``
        long (``truncated`` says one stopped there): ``boundary_edges`` and ``non_manifold_edges``
        (k, 2) vertex pairs, ``non_manifold_vertices`` (k,), ``degenerate_faces`` (k,) faces,
        ``self_intersections`` (k, 2) face pairs (``self_intersections_complete``,
        ``unchecked_faces``); ``components`` (each with ``faces``, ``volume`` in m³ and ``runs``
        (r, 2) [first face, count]) and ``largest_component``. With ``geometry`` (one request more,
        the upload's surface) also ``geometry``: the defects' coordinates in metres, float32,
        ``boundary_edges`` and ``non_manifold_edges`` (k, 2, 3) segment ends,
        ``non_manifold_vertices`` (k, 3), ``degenerate_faces`` (k, 3, 3) triangle corners and
        ``self_intersections`` (k, 2, 3, 3) triangle pairs. An id not of this session raises
        ServiceError 404 naming field ``id``."""
        answer = self._request("GET", lambda: self._upload_path(upload, "/defects"))
        out = dict(answer)
        for key, width in _DEFECT_LISTS.items():
            out[key] = np.asarray(answer[key], dtype=np.int64).reshape((-1, width) if width else (-1,))
        out["components"] = [dict(c, runs=np.asarray(c["runs"], dtype=np.int64).reshape(-1, 2))
                             for c in answer["components"]]
        if geometry:
            surface = self.upload_surface(upload)
            p, f = surface["positions"], surface["indices"].astype(np.int64)
            out["geometry"] = {
                "boundary_edges": p[out["boundary_edges"]],
                "non_manifold_edges": p[out["non_manifold_edges"]],
                "non_manifold_vertices": p[out["non_manifold_vertices"]],
                "degenerate_faces": p[f[out["degenerate_faces"]]],
                "self_intersections": p[f[out["self_intersections"]]],
            }
        return out

    def _upload_path(self, upload: str, tail: str = "") -> str:
        """An upload's path in the current session (its id quoted: an id is never a path)."""
        if not isinstance(upload, str):
            raise InvalidInputType("id", f"an upload id is a string, got {type(upload).__name__}")
        return f"/api/kelvin/uploads/{quote(self._current(upload), safe='')}{tail}"

    def kelvin_object(self, *, asset: Optional[str] = None, upload: Optional[str] = None,
                      mesh: Optional[Tuple[Any, Any]] = None, lx: Optional[float] = None,
                      lx_fraction: Optional[float] = None, center=None, far_radius=None, grading=None,
                      sigma: Optional[Mapping[str, Any]] = None, levels=None, repair: str = "none",
                      repair_options: Optional[Mapping[str, Any]] = None, simplify: Optional[int] = None,
                      components: Optional[str] = None,
                      progress: Optional[Callable[[str, float], Any]] = None, wait: bool = True) -> "KelvinObject":
        """Creates a Kelvin object from a built-in ``asset``, an ``upload`` id or ``mesh`` =
        (vertices, faces), with ``lx`` (metres) or ``lx_fraction`` (of the bounding-box diagonal);
        ``repair`` "fix" or "wrap" (``repair_options``: max_hole_edges; alpha, offset) makes an open
        or non-manifold mesh closed first; ``simplify`` (faces) reduces a scan first (the server's
        ``max_object_triangles`` bounds what it prepares); ``components`` "all" or "largest". With ``wait`` waits for its preparation
        (``progress(stage, fraction)``)."""
        if (lx is None) == (lx_fraction is None):
            raise ValueError("give lx or lx_fraction, exactly one")
        if repair not in ("none", "fix", "wrap"):
            raise ValueError("repair must be 'none', 'fix' or 'wrap'")
        body: Dict[str, Any] = {"lx": lx} if lx is not None else {"lx_fraction": lx_fraction}
        if repair != "none":
            body["repair"] = repair
        if repair_options is not None:
            body["repair_options"] = _plain(repair_options)
        if simplify is not None:
            body["simplify"] = {"faces": simplify}
        if components is not None:
            body["components"] = components
        if asset is not None:
            body["asset"] = asset
        if upload is not None:
            body["upload"] = self._current(upload)
        if mesh is not None:
            body["mesh"] = {"vertices": np.asarray(mesh[0]).tolist(), "faces": np.asarray(mesh[1]).tolist()}
        for key, value in (("center", center), ("far_radius", far_radius), ("grading", grading), ("sigma", sigma), ("levels", levels)):
            if value is not None:
                body[key] = _plain(value)
        answer = self._request("POST", "/api/kelvin/objects", json=body)
        obj = KelvinObject(self, answer["object"]["id"], answer["job"]["id"])
        if self.recover:
            obj._body = body
            self._objects.append(obj)
        if wait:
            self.wait(obj.job, progress)
        return obj

    def live(self) -> "Live":
        """The session's WebSocket: σ edits and the mesh frames they produce (see :class:`Live`)."""
        return Live(self)

    # -- CBF ------------------------------------------------------------------------------------

    def cbf_rollout(self, scenario: Union[str, Mapping[str, Any]], metric: str = "gap",
                    params: Optional[Mapping[str, Any]] = None, batch_steps: int = 50) -> Iterator[dict]:
        """Starts a rollout and yields its steps as they stream over the WebSocket (each a dict:
        ``i``, ``t``, ``q`` (7,), ``u`` (7,), ``distance``, ``witness_a`` ..., numpy arrays), in
        order, each once; stops after the last step. A failed rollout raises ServiceError; closing
        the iterator early cancels the job."""
        ws = self._ws()
        job_id = None
        try:
            hello = json.loads(ws.recv())
            assert hello.get("type") == "hello", hello
            body: Dict[str, Any] = {"scenario": _plain(scenario), "metric": metric,
                                    "stream": {"batch_steps": batch_steps}}
            if params is not None:
                body["params"] = _plain(params)
            answer = self._request("POST", "/api/cbf/rollouts", json=body)
            rollout_id, job_id = answer["rollout"]["id"], answer["job"]["id"]
            nxt, total, final = 0, None, None
            while total is None or nxt < total:
                message = ws.recv()
                if isinstance(message, bytes):
                    continue  # mesh frames of Kelvin objects
                m = json.loads(message)
                if m.get("type") == "cbf_frames" and m.get("rollout") == rollout_id:
                    total = m.get("steps_total", total)
                    for frame in m["frames"]:
                        if frame["i"] == nxt:
                            nxt += 1
                            yield _arrays(frame)
                elif m.get("type") == "job" and m["job"]["id"] == job_id and \
                        m["job"]["state"] in ("succeeded", "failed", "cancelled"):
                    final = m["job"]
                    break
            if final is not None:  # the job ended: the rest from the REST record of its frames
                if final["state"] != "succeeded":
                    e = final.get("error") or {}
                    raise ServiceError(422, e.get("code", final["state"]), e.get("field", ""),
                                       e.get("message", final["state"]))
                while True:
                    page = self._request("GET", f"/api/cbf/rollouts/{rollout_id}/frames", params={"from": nxt})
                    if not page["frames"]:
                        break
                    for frame in page["frames"]:
                        if frame["i"] == nxt:
                            nxt += 1
                            yield _arrays(frame)
            job_id = None
        finally:
            if job_id is not None:
                try:
                    self.cancel(job_id)
                except Exception:  # noqa: BLE001  (best effort on the way out)
                    pass
            ws.close()

    def cbf_sweep(self, scenario: Union[str, Mapping[str, Any]], parameter: str, values, metric: str = "gap",
                  params: Optional[Mapping[str, Any]] = None, *,
                  progress: Optional[Callable[[str, float], Any]] = None, wait: bool = True) -> "CbfSweep":
        """Starts a parameter sweep as one job (POST /api/cbf/sweeps; the arguments and the
        entries as :func:`distlab.cbf.sweep`'s, the runs in parallel on the service's compute
        pool). With ``wait`` waits for it (``progress(stage, fraction)``; Ctrl-C cancels it on the
        service). Bad input raises ServiceError naming the field before any job starts."""
        body: Dict[str, Any] = {"scenario": _plain(scenario), "metric": metric,
                                "sweep": {"parameter": parameter, "values": _plain(list(values))}}
        if params is not None:
            body["params"] = _plain(params)
        answer = self._request("POST", "/api/cbf/sweeps", json=body)
        sweep = CbfSweep(self, answer["sweep"]["id"], answer["job"]["id"])
        if wait:
            sweep.wait(progress)
        return sweep


class Live:
    """The session's WebSocket (``with client.live() as live: ...``). :meth:`watch` chooses an
    object's iso-levels, :meth:`set_sigma` sends a σ edit and waits for its acknowledgement (the
    new σ version); :meth:`messages` yields what the service pushes: mesh frames (binary msgpack,
    decoded by :func:`decode_mesh_frame` into numpy views without copies) and JSON messages as dicts
    (``job``, ``object``, ``sigma``, ``cbf_frames`` ...). ``hello`` is the service's first message."""

    def __init__(self, client: Client):
        self.client = client
        self.ws = client._ws()
        self.hello = json.loads(self.ws.recv())
        self._pending: list = []
        self._request = 0

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()

    def close(self) -> None:
        """Closes the WebSocket (the session stays)."""
        self.ws.close()

    def _receive(self) -> dict:
        message = self.ws.recv()
        if isinstance(message, bytes):
            return decode_mesh_frame(message)
        return json.loads(message)

    def _call(self, message: dict) -> dict:
        """Sends a message with a fresh request id; its reply (other messages wait in order)."""
        self._request += 1
        message["request"] = self._request
        self.ws.send(json.dumps(message))
        while True:
            m = self._receive()
            if m.get("request") == self._request:
                if m.get("type") == "error":
                    e = m["error"]
                    raise ServiceError(m.get("status", 400), e.get("code", ""), e.get("field", ""), e.get("message", ""))
                return m
            self._pending.append(m)

    def watch(self, obj: "KelvinObject", levels) -> None:
        """Iso-surfaces {h = level} of ``obj`` for each level, pushed as frames after each σ."""
        self.ws.send(json.dumps({"type": "watch", "object": obj.id, "levels": _plain(levels)}))

    def set_sigma(self, obj: "KelvinObject", per_vertex=None, *, constant: Optional[float] = None, axis=None,
                  brushes=None) -> int:
        """A σ edit over the WebSocket (as :meth:`KelvinObject.set_sigma`); its σ version once
        accepted. A refused σ raises ServiceError naming the field."""
        sigma: Dict[str, Any] = {}
        for key, value in (("per_vertex", per_vertex), ("constant", constant), ("axis", axis), ("brushes", brushes)):
            if value is not None:
                sigma[key] = _plain(value)
        version = self._call({"type": "sigma", "object": obj.id, "sigma": sigma})["sigma_version"]
        obj._sigma = sigma
        return version

    def messages(self) -> Iterator[dict]:
        """What the service pushes, in order of arrival (blocks; the client's timeout applies)."""
        while True:
            yield self._pending.pop(0) if self._pending else self._receive()

    def isosurfaces(self, obj: "KelvinObject", sigma_version: int) -> Dict[float, dict]:
        """Waits for the iso-surface frames of every watched level of ``obj`` at ``sigma_version``
        (a newer σ supersedes them: then raises RuntimeError); {level: frame}."""
        frames: Dict[float, dict] = {}
        for m in self.messages():
            if m.get("type") != "isosurface" or m.get("object") != obj.id:
                continue
            if m["sigma_version"] > sigma_version:
                raise RuntimeError(f"σ version {m['sigma_version']} superseded {sigma_version}")
            if m["sigma_version"] == sigma_version:
                frames[m["level"]] = m
                if len(frames) == m["count"]:
                    return frames
        raise AssertionError("unreachable")


class CbfSweep:
    """A parameter sweep of the client's session (a job: the job vocabulary of :meth:`Client.job`,
    :meth:`Client.wait` and :meth:`Client.cancel` applies to ``job``)."""

    def __init__(self, client: Client, sweep_id: str, job: str):
        self.client, self.id, self.job = client, sweep_id, job

    def status(self) -> dict:
        """GET /api/cbf/sweeps/ID: ``entries`` finished so far (in the sweep's order; each names
        its ``index`` in ``values``), ``job`` (state, stage, fraction), and the sweep's head."""
        return _arrays(self.client._request("GET", f"/api/cbf/sweeps/{self.id}"))

    def progress(self) -> Tuple[str, float]:
        """The job's (stage, fraction): stage "K of N runs done", fraction over all runs' steps."""
        job = self.client.job(self.job)
        return job.get("stage", ""), job.get("fraction", 0.0)

    def wait(self, progress: Optional[Callable[[str, float], Any]] = None, timeout: float = 3600) -> dict:
        """Waits for the sweep (as :meth:`Client.wait`: a failed or cancelled sweep raises
        ServiceError, Ctrl-C cancels it); its result."""
        self.client.wait(self.job, progress, timeout=timeout)
        return self.result()

    def cancel(self) -> None:
        """Cancels the sweep; the runs finished before stay in :meth:`result`."""
        self.client.cancel(self.job)

    def result(self) -> dict:
        """``{"scenario", "metric", "parameter", "values", "entries"}`` as :func:`distlab.cbf.sweep`
        returns them (entries of the runs finished so far), numeric arrays as numpy arrays."""
        out = self.status()
        out.pop("job", None)
        out.pop("id", None)
        return out


class KelvinObject:
    """A Kelvin object of the client's session."""

    def __init__(self, client: Client, object_id: str, job: str):
        self.client, self.id, self.job = client, object_id, job
        self._body: Dict[str, Any] = {}  # the request that made it, and its last σ: a recovery's
        self._sigma: Optional[Dict[str, Any]] = None

    def _path(self, tail: str = "") -> str:
        return f"/api/kelvin/objects/{self.id}{tail}"

    def info(self) -> dict:
        """State, stats, sigma_version, levels."""
        return _arrays(self.client._request("GET", self._path))

    def set_sigma(self, per_vertex=None, *, constant: Optional[float] = None, axis=None, brushes=None) -> dict:
        """PUT σ (the terms add up; per_vertex in the file's vertex order); the new sigma state."""
        body: Dict[str, Any] = {}
        for key, value in (("per_vertex", per_vertex), ("constant", constant), ("axis", axis), ("brushes", brushes)):
            if value is not None:
                body[key] = _plain(value)
        answer = self.client._request("PUT", lambda: self._path("/sigma"), json=body)
        self._sigma = body
        return answer

    def query(self, points) -> Tuple[np.ndarray, np.ndarray, np.ndarray]:
        """h (N,), ∇h (N, 3) (NaN where undefined) and inside (N,) at points (N, 3)."""
        p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        r = self.client._request("POST", lambda: self._path("/query"), json={"points": p.tolist()})
        h = np.array([np.nan if v is None else v for v in r["h"]], dtype=np.float64)
        g = np.array([[np.nan] * 3 if v is None else v for v in r["gradient"]], dtype=np.float64).reshape(-1, 3)
        return h, g, np.array(r["inside"], dtype=bool)

    def isosurface(self, level: float) -> Tuple[np.ndarray, np.ndarray]:
        """The iso-surface {h = level}: vertices (n, 3) float32, faces (m, 3) uint32."""
        f = decode_mesh_frame(self.client._request("GET", lambda: self._path("/isosurface"), params={"level": level}, raw=True))
        return f["positions"], f["indices"]

    def surface(self) -> dict:
        """The object's surface frame (positions, indices, σ per vertex as scalars)."""
        return decode_mesh_frame(self.client._request("GET", lambda: self._path("/surface"), raw=True))

    def export(self, path: Union[str, os.PathLike], level: float, format: Optional[str] = None) -> None:
        """Downloads the iso-surface {h = level} as STL, OBJ, PLY or GLB into ``path``."""
        fmt = format or os.path.splitext(os.fspath(path))[1].lstrip(".").lower()
        data = self.client._request("GET", lambda: self._path("/export"), params={"level": level, "format": fmt}, raw=True)
        with open(path, "wb") as f:
            f.write(data)

    def delete(self) -> None:
        """Deletes the object from the session."""
        self.client._request("DELETE", self._path)
        if self in self.client._objects:
            self.client._objects.remove(self)


# GET /api/kelvin/uploads/ID/defects: its lists and their row widths (0: a flat list).
_DEFECT_LISTS = {"boundary_edges": 2, "non_manifold_edges": 2, "non_manifold_vertices": 0, "degenerate_faces": 0,
                 "self_intersections": 2}


def _digest(digest) -> str:
    """A mesh digest as the service takes it (it checks the 64 hex digits and names ``digest``)."""
    if not isinstance(digest, str):
        raise InvalidInputType("digest", f"digest must be a string of 64 hex digits, got {type(digest).__name__}")
    return digest


def _plain(x):
    """numpy arrays and scalars as JSON-ready lists and numbers."""
    if isinstance(x, np.ndarray):
        return x.tolist()
    if isinstance(x, np.generic):
        return x.item()
    if isinstance(x, Mapping):
        return {k: _plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_plain(v) for v in x]
    return x
