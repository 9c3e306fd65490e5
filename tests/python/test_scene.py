"""Client.scene and Client.record against the real `distlab serve` with the built front end: items
reach the session's own sockets (and no other session's), bad items are refused naming the field,
and recordings made by the page in headless chromium show the items where they are."""

import _thread
import json
import threading

import matplotlib.image
import numpy as np
import pytest

import distlab
from distlab.client import ServiceError, decode_mesh_frame
from conftest import ROOT, serving

LIMITS = {"max_scene_items": 3, "max_scene_vertices": 1000, "max_record_frames": 8}


@pytest.fixture(scope="module")
def server(exe):
    web = ROOT / "web" / "dist"
    if not (web / "index.html").exists():
        pytest.fail(f"no front-end build at {web} (bash .ci/build-web)")
    limits = [a for k, v in LIMITS.items() for a in ("--limit", f"{k}={v}")]
    with serving(exe, "--web", str(web), "--threads", "2", *limits) as url:
        yield url


def until_pong(live):
    """The messages the socket got before the answer to a ping sent now (all the server had queued)."""
    live.ws.send(json.dumps({"type": "ping"}))
    out = []
    for m in live.messages():
        if m.get("type") == "pong":
            return out
        out.append(m)


def scene_messages(messages):
    return [m for m in messages if str(m.get("type", "")).startswith("scene")]


def test_items_stream_to_the_sessions_own_sockets(server):
    a, b = distlab.Client(server), distlab.Client(server)
    with a.live() as mine, b.live() as other:
        V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
        F = np.array([[0, 1, 2], [0, 1, 3]])
        colors = np.array([[1, 0, 0], [0, 1, 0], [0, 0, 1], [1, 1, 0]], float)
        kept = a.scene.add_mesh("tetra", V, F, colors=colors, view="kelvin")
        assert kept == {"name": "tetra", "kind": "mesh", "view": "kelvin", "n_vertices": 4, "n_faces": 2, "bytes": kept["bytes"]}
        T = np.eye(4)
        T[:3, :3] = [[0, -1, 0], [1, 0, 0], [0, 0, 1]]  # 90° about z
        T[:3, 3] = [0.5, -0.25, 2]
        a.scene.set_pose("tetra", T)
        a.scene.add_points("dots", V * 2, values=[0, 1, 2, 3], size=4)
        a.scene.remove("dots")
        got = scene_messages(until_pong(mine))
        assert [m["type"] for m in got] == ["scene_item", "scene_pose", "scene_item", "scene_remove"]
        frame = got[0]
        assert frame["name"] == "tetra" and frame["kind"] == "mesh" and frame["view"] == "kelvin"
        np.testing.assert_array_equal(frame["positions"], V.astype(np.float32))
        np.testing.assert_array_equal(frame["indices"], F)
        np.testing.assert_array_equal(frame["colors"], colors.astype(np.float32))
        assert got[1]["name"] == "tetra" and got[1]["pose"]["position"] == [0.5, -0.25, 2]
        np.testing.assert_allclose(got[1]["pose"]["quaternion"], [np.sqrt(0.5), 0, 0, np.sqrt(0.5)], atol=1e-12)
        np.testing.assert_array_equal(got[2]["scalars"], [0, 1, 2, 3])
        assert got[3] == {"type": "scene_remove", "name": "dots"}
        assert scene_messages(until_pong(other)) == []  # one client never sees another's scene
    # A page that joins later gets the items there are, with their latest pose.
    with a.live() as late:
        joined = scene_messages(until_pong(late))
        assert [(m["type"], m["name"]) for m in joined] == [("scene_item", "tetra")]
        assert joined[0]["pose"]["position"] == [0.5, -0.25, 2]
    a.scene.add_lines("path", V)  # a polyline: 3 segments
    a.scene.add_frame("origin", [0, 0, 0, 1, 0, 0, 0], size=0.2)
    assert {i["name"]: i.get("n_segments") for i in a.scene.items()} == {"origin": None, "path": 3, "tetra": None}
    with a.live() as watching:
        until_pong(watching)
        a.scene.clear()
        assert scene_messages(until_pong(watching)) == [{"type": "scene_clear"}]
    assert a.scene.items() == []


def test_bad_items_are_refused_naming_the_field(server, tmp_path):
    c = distlab.Client(server)
    V = np.zeros((3, 3))
    V[1, 0] = V[2, 1] = 1
    F = np.array([[0, 1, 2]])
    cases = [
        (lambda: c.scene.add_mesh("m", np.where(np.arange(9).reshape(3, 3) == 5, np.nan, V), F), 400, "positions[1][2]"),
        (lambda: c.scene.add_mesh("m", V, [[0, 1, 3]]), 400, "indices[0][2]"),
        (lambda: c.scene.add_mesh("m", V, F, view="plots"), 400, "view"),
        (lambda: c.scene.add_mesh("m", V, F, colors=np.full((3, 3), 2.0)), 400, "colors[0][0]"),
        (lambda: c._request("PUT", "/api/scene/items/bad%20name", data=b"\x80"), 400, "name"),
        (lambda: c.scene.add_points("p", np.zeros((LIMITS["max_scene_vertices"] + 1, 3))), 413, "positions"),
        (lambda: c.scene.set_pose("nothing", np.eye(4)), 404, "name"),
        (lambda: c.record(tmp_path, frames=LIMITS["max_record_frames"] + 1), 413, "frames"),
        (lambda: c.record(tmp_path, frames=1, view="plots"), 400, "view"),
    ]
    for call, status, field in cases:
        with pytest.raises(ServiceError) as info:
            call()
        assert (info.value.status, info.value.field) == (status, field), info.value
    for i in range(LIMITS["max_scene_items"]):
        c.scene.add_points(f"p{i}", V)
    c.scene.add_points("p0", V * 2)  # replacing an item is no new item
    with pytest.raises(ServiceError) as info:
        c.scene.add_points("one_more", V)
    assert (info.value.status, info.value.code, info.value.field) == (413, "too_many_items", "name")
    # Hostile frames: nesting, a bin longer than the body, a duplicate key, a bin of 5 bytes.
    for body, field in [(b"\x91" * 100000, ""), (b"\xc6\xff\xff\xff\xff", "body"),
                        (b"\x82\xa4kind\xa4mesh\xa4kind\xa4mesh", "kind"),
                        (b"\x82\xa4kind\xa6points\xa9positions\xc4\x05abcde", "positions")]:
        with pytest.raises(ServiceError) as info:
            c._request("PUT", "/api/scene/items/m", data=body)
        assert (info.value.status, info.value.field) == (400, field), info.value
    # Shapes, numbers, names and the file kind are the client's to check, naming the field.
    for call, field in [(lambda: c.scene.add_mesh("m", V.ravel(), F), "positions"),
                        (lambda: c.scene.add_points("p", [["a", "b", "c"]]), "positions"),
                        (lambda: c.scene.set_pose("p0", [np.nan, 0, 0]), "pose[0]"),
                        (lambda: c.scene.set_pose("p0", ([0, 0, 0], [1, 0, "x", 0])), "pose.quaternion"),
                        (lambda: c.scene.add_mesh("a/b", V, F), "name"),
                        (lambda: c.scene.remove(""), "name"),
                        (lambda: c.record("clip.mp4", frames=1), "path")]:
        with pytest.raises(distlab.InvalidInput) as info:
            call()
        assert not isinstance(info.value, ServiceError) and info.value.field == field, info.value


def unproject(M, ndc):
    """The world point at normalised device coordinates (x, y, z) of the clip matrix M."""
    p = np.linalg.solve(M, np.append(ndc, 1.0))
    return p[:3] / p[3]


def pixel(camera, world):
    """(row, column) where the page drew the world point (the PNG's top row is y = +1)."""
    M = np.array(camera["matrix"]).reshape(4, 4).T  # three.js elements are column-major
    c = M @ np.append(world, 1.0)
    x, y = c[:2] / c[3]
    return int((1 - y) / 2 * camera["height"]), int((x + 1) / 2 * camera["width"])


def red_at(png, rc, r=3):
    """Whether the patch around (row, column) is drawn red (shaded: red well above green and blue)."""
    patch = matplotlib.image.imread(png)[rc[0] - r:rc[0] + r + 1, rc[1] - r:rc[1] + r + 1, :3]
    return bool(np.all((patch[..., 0] > 0.1) & (patch[..., 0] > 2 * patch[..., 1]) & (patch[..., 0] > 2 * patch[..., 2])))


def cube(center, half):
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float) * half + center
    faces = [[0, 1, 3], [0, 3, 2], [4, 6, 7], [4, 7, 5], [0, 4, 5], [0, 5, 1], [2, 3, 7], [2, 7, 6], [0, 2, 6], [0, 6, 4],
             [1, 5, 7], [1, 7, 3]]
    return corners, np.array(faces)


def test_record_png_shows_the_mesh_where_it_is(server, tmp_path):
    c = distlab.Client(server)
    first = c.record(tmp_path / "before", frames=1, view="gap", width=640, height=480)
    M = np.array(first["camera"]["matrix"]).reshape(4, 4).T
    # A red cube in front of everything, around the point drawn at (0.4, 0.4) of the canvas, and
    # where the move takes it: (-0.4, -0.4).
    here, there = unproject(M, [0.4, 0.4, 0.5]), unproject(M, [-0.4, -0.4, 0.5])
    half = 0.5 * np.linalg.norm(unproject(M, [0.5, 0.4, 0.5]) - here)
    V, F = cube(np.zeros(3), half)
    c.scene.add_mesh("box", V, F, color=(1, 0, 0), pose=here)
    shown = c.record(tmp_path / "shown", frames=2, view="gap", width=640, height=480)
    assert [f.rsplit("/", 1)[1] for f in shown["files"]] == ["frame_0000.png", "frame_0001.png"]
    assert shown["recorded"]["frames"] == 2 and shown["recorded"]["seconds"] >= 2 / shown["fps"]
    assert all(red_at(f, pixel(shown["camera"], here)) for f in shown["files"])
    assert not red_at(shown["files"][0], pixel(shown["camera"], there))
    c.scene.set_pose("box", there)
    moved = c.record(tmp_path / "new" / "moved_%02d.png", frames=1, view="gap", width=640, height=480)
    assert moved["files"] == [str(tmp_path / "new" / "moved_00.png")]
    assert red_at(moved["files"][0], pixel(moved["camera"], there))
    assert not red_at(moved["files"][0], pixel(moved["camera"], here))
    # An item for another view is not drawn in this one.
    c.scene.add_mesh("box", V, F, color=(1, 0, 0), pose=there, view="cbf")
    elsewhere = c.record(tmp_path / "gap_only.png", frames=1, view="gap", width=640, height=480)
    assert not red_at(elsewhere["files"][0], pixel(elsewhere["camera"], there))
    c.scene.remove("box")
    gone = c.record(tmp_path / "gone", frames=1, view="gap", width=640, height=480)
    assert not red_at(gone["files"][0], pixel(gone["camera"], there))
    assert not red_at(gone["files"][0], pixel(gone["camera"], here))


def ebml_blocks(data):
    """(DocType, [(cluster timecode + block timecode) of each frame]) of a WebM file: a flat walk that
    enters the EBML header, the Segment, Clusters (sizes may be unknown) and BlockGroups, reads
    SimpleBlocks and Blocks, and skips every other element."""
    def vint(i, keep_marker):
        first = data[i]
        n = 8 - first.bit_length() + 1
        v = int.from_bytes(data[i:i + n], "big")
        return (v if keep_marker else v & ((1 << (7 * n)) - 1)), i + n, n

    entered = {0x1A45DFA3, 0x18538067, 0x1F43B675, 0xA0}
    i, doctype, cluster, times = 0, None, 0, []
    while i < len(data):
        eid, i, _ = vint(i, True)
        size, i, n = vint(i, False)
        if eid in entered:
            continue
        if size == (1 << (7 * n)) - 1:
            raise AssertionError(f"unknown size of element {eid:#x}")
        body = data[i:i + size]
        if eid == 0x4282:
            doctype = body.decode()
        elif eid == 0xE7:
            cluster = int.from_bytes(body, "big")
        elif eid in (0xA3, 0xA1):
            _, k, _ = vint(i, False)  # track number
            times.append(cluster + int.from_bytes(data[k:k + 2], "big", signed=True))
        i += size
    return doctype, times


def test_record_webm_has_frames_and_a_duration(server, tmp_path):
    c = distlab.Client(server)
    c.scene.add_frame("axes", np.eye(4), size=0.5)
    rec = c.record(tmp_path / "view.webm", seconds=1, view="gap", fps=LIMITS["max_record_frames"])
    data = (tmp_path / "view.webm").read_bytes()
    assert data[:4] == bytes.fromhex("1a45dfa3") and rec["parts"] == 1 and rec["bytes"] == len(data)
    doctype, times = ebml_blocks(data)
    assert doctype == "webm"
    # The file holds the frames asked for (a slow renderer makes it longer, not shorter), and
    # the recording says how long it is, read from the file's own block times (the page's clock
    # runs ahead of the encoder's on a loaded machine): their span plus the last frame's 1 / fps.
    fps = LIMITS["max_record_frames"]
    assert rec["recorded"]["frames"] == len(times) == fps, (rec, times)
    assert abs((max(times) - min(times)) / 1000 + 1 / fps - rec["recorded"]["seconds"]) <= 1e-9, (rec, times)


def test_a_cancelled_recording_is_forgotten(server, tmp_path):
    c = distlab.Client(server)
    rec = c._request("POST", "/api/scene/recordings", json={"view": "gap", "format": "png", "frames": 1})
    c._request("DELETE", f"/api/scene/recordings/{rec['id']}")
    with pytest.raises(ServiceError) as info:  # what the page's next part gets: it stops
        c._request("PUT", f"/api/scene/recordings/{rec['id']}/parts/0", data=b"png")
    assert (info.value.status, info.value.code) == (404, "unknown_recording")


def test_ctrl_c_stops_a_recording_and_the_service_forgets_it(server, tmp_path):
    c = distlab.Client(server)
    made, request = [], c._request

    def spy(method, route, **kw):  # Ctrl-C once the recording exists and its page is starting
        answer = request(method, route, **kw)
        if (method, route) == ("POST", "/api/scene/recordings"):
            made.append(answer["id"])
            threading.Timer(0.5, _thread.interrupt_main).start()
        return answer

    c._request = spy
    with pytest.raises(KeyboardInterrupt):
        c.record(tmp_path / "long.webm", seconds=LIMITS["max_record_frames"], fps=1, view="gap")
    with pytest.raises(ServiceError) as info:
        request("GET", f"/api/scene/recordings/{made[0]}")
    assert (info.value.status, info.value.code) == (404, "unknown_recording")
    assert not (tmp_path / "long.webm").exists()
