"""Your own geometry in the service's views, and recordings of a view (``Client.scene``,
``Client.record``).

An item is sent as one msgpack frame, the codec of the service's mesh frames (float32 positions,
uint32 indices, float32 per-vertex colours or values), and relayed by the service to the pages of
this client's session only (open one with :meth:`distlab.Client.page_url`). The service checks
every item (finite coordinates, indices in range, the scene limits of ``/api/limits``) and refuses
bad ones with :class:`distlab.client.ServiceError` (an ``InvalidInput``) naming the field:
``positions[i][k]``, ``indices[f][k]``, ``colors[i][k]``, ``name``, ``view``.

A recording is made by a page of the session in headless chromium: the service cannot draw (no
WebGL there), and the page is what the user sees, so the recording shows exactly that. The page
records its canvas (WebM through the browser's MediaRecorder, or one PNG per frame), uploads it
to the service, and :func:`record` fetches it."""

from __future__ import annotations

import os
import re
import shutil
import signal
import subprocess
import tempfile
import time
from typing import TYPE_CHECKING, Any, Dict, List, Optional

import msgpack
import numpy as np

from .errors import InvalidInput

if TYPE_CHECKING:
    from .client import Client

__all__ = ["Scene", "record", "pose_json"]

_VIEWS = ("all", "gap", "kelvin", "cbf")
_NAME = re.compile(r"^[A-Za-z0-9_-]{1,64}$")  # the service's rule for an item's name (routes_scene.cpp)


def _name(name) -> str:
    """An item's name, checked here so that a '/' or an empty name is not read as another route."""
    if not isinstance(name, str) or not _NAME.match(name):
        raise InvalidInput("name", f"an item's name has 1 to 64 letters, digits, '_' and '-', got {name!r}")
    return name


def _numbers(x, field: str) -> np.ndarray:
    """x as float64, refused naming the field when it does not hold finite numbers."""
    a = np.asarray(x)
    if a.dtype.kind not in "biuf":
        raise InvalidInput(field, f"{field} must hold numbers, got {a.dtype} ({np.ravel(a)[:1].tolist()}...)")
    a = a.astype(np.float64)
    if not np.all(np.isfinite(a)):
        bad = np.argwhere(~np.isfinite(a))[0]
        raise InvalidInput(field + "".join(f"[{i}]" for i in bad), f"{field} must be finite")
    return a


def pose_json(pose, field: str = "pose") -> dict:
    """A pose as the service reads it ({"position", "quaternion" [w, x, y, z]}) from a 4x4 rigid
    transform, ``[x, y, z, qw, qx, qy, qz]``, a position (3,), or ``(position, quaternion)``."""
    if isinstance(pose, tuple) and len(pose) == 2:
        return {"position": _numbers(pose[0], field + ".position").tolist(),
                "quaternion": _numbers(pose[1], field + ".quaternion").tolist()}
    p = _numbers(pose, field)
    if p.shape == (3,):
        return {"position": p.tolist()}
    if p.shape == (7,):
        return {"position": p[:3].tolist(), "quaternion": p[3:].tolist()}
    if p.shape != (4, 4):
        raise InvalidInput(field, f"{field} must be a 4x4 transform, [x, y, z, qw, qx, qy, qz] or a position (3,); got shape {p.shape}")
    R = p[:3, :3]
    if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) <= 0 \
            or not np.array_equal(p[3], [0, 0, 0, 1]):
        raise InvalidInput(field, f"{field} must be a rigid transform (orthonormal rotation, det +1, last row 0 0 0 1)")
    # Shepperd's method: the largest of w, x, y, z first, then the others from it.
    t = np.trace(R)
    cand = [1 + t, 1 + 2 * R[0, 0] - t, 1 + 2 * R[1, 1] - t, 1 + 2 * R[2, 2] - t]
    k = int(np.argmax(cand))
    s = 2 * np.sqrt(cand[k])
    if k == 0:
        q = [s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s]
    elif k == 1:
        q = [(R[2, 1] - R[1, 2]) / s, s / 4, (R[0, 1] + R[1, 0]) / s, (R[0, 2] + R[2, 0]) / s]
    elif k == 2:
        q = [(R[0, 2] - R[2, 0]) / s, (R[0, 1] + R[1, 0]) / s, s / 4, (R[1, 2] + R[2, 1]) / s]
    else:
        q = [(R[1, 0] - R[0, 1]) / s, (R[0, 2] + R[2, 0]) / s, (R[1, 2] + R[2, 1]) / s, s / 4]
    return {"position": p[:3, 3].tolist(), "quaternion": [float(v) for v in q]}


def _rows(a, width: int, dtype, field: str) -> bytes:
    """An (N, width) array as little-endian bytes of dtype (the frame's bin value)."""
    x = np.asarray(a)
    if x.ndim != 2 or x.shape[1] != width:
        raise InvalidInput(field, f"{field} must have shape (N, {width}), got {x.shape}")
    if np.dtype(dtype).kind == "u":
        if x.dtype.kind not in "iu":
            raise InvalidInput(field, f"{field} must hold integers, got {x.dtype}")
        if x.size and x.min() < 0:
            bad = np.argwhere(x < 0)[0]
            raise InvalidInput(f"{field}[{bad[0]}][{bad[1]}]", f"{field} must be >= 0")
    elif x.dtype.kind not in "biuf":
        raise InvalidInput(field, f"{field} must hold numbers, got {x.dtype}")
    return np.ascontiguousarray(x, dtype=np.dtype(dtype).newbyteorder("<")).tobytes()


class Scene:
    """The items of the client's session, by name (``client.scene``). Adding under a name that
    exists replaces that item. Each method returns the item as the service keeps it (name, kind,
    view, n_vertices, n_faces / n_segments, pose, bytes)."""

    def __init__(self, client: "Client"):
        self.client = client

    def _put(self, name: str, kind: str, view: str, positions=None, indices=None, index_width: int = 0, *,
             color=None, colors=None, values=None, size=None, pose=None) -> dict:
        frame: Dict[str, Any] = {"kind": kind, "view": view}
        if positions is not None:
            frame["positions"] = _rows(positions, 3, "<f4", "positions")
        if indices is not None:
            frame["indices"] = _rows(indices, index_width, "<u4", "indices")
        if colors is not None:
            frame["colors"] = _rows(colors, 3, "<f4", "colors")
        if values is not None:
            frame["scalars"] = _rows(np.asarray(values).reshape(-1, 1), 1, "<f4", "scalars")
        if color is not None:
            frame["color"] = [float(c) for c in color]
        if size is not None:
            frame["size"] = float(size)
        if pose is not None:
            frame["pose"] = pose_json(pose)
        return self.client._request("PUT", f"/api/scene/items/{_name(name)}", data=msgpack.packb(frame, use_bin_type=True),
                                    headers={"Content-Type": "application/msgpack"})

    def add_mesh(self, name: str, vertices, faces, *, color=None, colors=None, values=None, pose=None,
                 view: str = "all") -> dict:
        """A triangle mesh: ``vertices`` (N, 3), ``faces`` (M, 3) vertex indices; ``color`` (r, g, b)
        in [0, 1] for all of it, or ``colors`` (N, 3) per vertex, or ``values`` (N,) drawn with a
        colormap; ``pose`` (4x4, [x, y, z, qw, qx, qy, qz] or a position) places its frame;
        ``view`` "gap", "kelvin", "cbf" or "all"."""
        return self._put(name, "mesh", view, vertices, faces, 3, color=color, colors=colors, values=values, pose=pose)

    def add_points(self, name: str, points, *, color=None, colors=None, values=None, size: Optional[float] = None,
                   pose=None, view: str = "all") -> dict:
        """Points (N, 3), ``size`` pixels each (default 6); colours as :meth:`add_mesh`."""
        return self._put(name, "points", view, points, color=color, colors=colors, values=values, size=size, pose=pose)

    def add_lines(self, name: str, points, segments=None, *, color=None, colors=None, values=None, pose=None,
                  view: str = "all") -> dict:
        """Line segments between ``points`` (N, 3): ``segments`` (M, 2) index pairs, or without them
        the polyline through the points in order; colours as :meth:`add_mesh`."""
        if segments is None:
            n = len(np.asarray(points))
            segments = np.stack([np.arange(n - 1), np.arange(1, n)], axis=1) if n > 1 else np.zeros((0, 2), int)
        return self._put(name, "lines", view, points, segments, 2, color=color, colors=colors, values=values, pose=pose)

    def add_frame(self, name: str, pose=None, *, size: float = 0.1, view: str = "all") -> dict:
        """A coordinate frame (x red, y green, z blue axes of length ``size`` metres) at ``pose``."""
        return self._put(name, "frame", view, size=size, pose=pose)

    def set_pose(self, name: str, pose) -> dict:
        """Moves an item: its new pose (4x4, [x, y, z, qw, qx, qy, qz] or a position)."""
        return self.client._request("PUT", f"/api/scene/items/{_name(name)}/pose", json={"pose": pose_json(pose)})

    def remove(self, name: str) -> None:
        """Removes an item (unknown names raise ServiceError, 404)."""
        self.client._request("DELETE", f"/api/scene/items/{_name(name)}")

    def clear(self) -> None:
        """Removes every item of the session."""
        self.client._request("DELETE", "/api/scene/items")

    def items(self) -> List[dict]:
        """The session's items as the service keeps them."""
        return self.client._request("GET", "/api/scene/items")["items"]


def _chromium() -> str:
    for name in (os.environ.get("CHROMIUM"), "chromium", "chromium-browser"):
        if name and shutil.which(name):
            return shutil.which(name)
    raise RuntimeError("Client.record needs chromium (Debian package chromium) on PATH or in $CHROMIUM")


def _png_paths(path: str, n: int) -> List[str]:
    """Where PNG frame i goes: DIR/frame_0000.png, or PATTERN % i (frame_%03d.png), or STEM_0000.png."""
    if path.endswith(".png"):
        os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
        if re.search(r"%0?\d*d", path):
            return [path % i for i in range(n)]
        return [f"{path[:-4]}_{i:04d}.png" for i in range(n)]
    os.makedirs(path, exist_ok=True)
    return [os.path.join(path, f"frame_{i:04d}.png") for i in range(n)]


def record(client: "Client", path, *, seconds: Optional[float] = None, frames: Optional[int] = None,
           view: str = "gap", fps: float = 30, width: int = 960, height: int = 600,
           timeout: float = 120) -> dict:
    """See :meth:`distlab.Client.record`."""
    path = os.fspath(path)
    fmt = "webm" if path.endswith(".webm") else "png"
    ext = os.path.splitext(path)[1].lower()
    if ext not in ("", ".webm", ".png") and not os.path.isdir(path):
        raise InvalidInput("path", f"a recording is a .webm video or PNG frames (a .png name or pattern, or a "
                                   f"directory), got {ext!r}")
    body: Dict[str, Any] = {"view": view, "format": fmt, "fps": fps}
    if seconds is not None:
        body["seconds"] = seconds
    if frames is not None:
        body["frames"] = frames
    rec = client._request("POST", "/api/scene/recordings", json=body)
    url = f"{client.url}/?session={client.session}&record={rec['id']}#/{view}"
    profile = tempfile.mkdtemp(prefix="distlab-record-")
    browser = subprocess.Popen(
        [_chromium(), "--headless=new", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
         "--disable-component-update", "--enable-unsafe-swiftshader", "--use-angle=swiftshader", "--mute-audio",
         f"--user-data-dir={profile}", f"--window-size={int(width)},{int(height)}", url],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, start_new_session=True)
    try:
        end = time.monotonic() + rec["seconds"] + timeout
        while rec["state"] not in ("done", "failed"):
            if browser.poll() is not None:
                raise RuntimeError(f"chromium exited ({browser.returncode}) before the recording was done")
            if time.monotonic() > end:
                raise TimeoutError(f"the recording was still {rec['state']} after {timeout} s beyond its length")
            time.sleep(0.1)
            rec = client._request("GET", f"/api/scene/recordings/{rec['id']}")
        if rec["state"] == "failed":
            raise RuntimeError(f"the page could not record: {rec.get('error', '')}")
        targets = [path] if fmt == "webm" else _png_paths(path, rec["parts"])
        for i, target in enumerate(targets):
            with open(target, "wb") as f:
                f.write(client._request("GET", f"/api/scene/recordings/{rec['id']}/parts/{i}", raw=True))
        rec["files"] = targets
        return rec
    finally:  # done, failed, or Ctrl-C: the service forgets it, and a page still recording stops
        # chromium's own children (renderer, GPU, crash handler) outlive a killed parent and keep
        # writing into the profile: end the whole group before the profile is removed.
        try:
            os.killpg(browser.pid, signal.SIGKILL)
        except ProcessLookupError:
            pass
        browser.wait()
        try:
            client._request("DELETE", f"/api/scene/recordings/{rec['id']}")
        except Exception:  # noqa: BLE001  (best effort on the way out)
            pass
        for _ in range(20):  # a file the group was writing as it died may appear once more
            shutil.rmtree(profile, ignore_errors=True)
            if not os.path.exists(profile):
                break
            time.sleep(0.05)
