"""distlab.Client against the real `distlab serve` on a free port: the same numbers as in-process."""

import json
import re
import signal
import subprocess
import tempfile
import time

import numpy as np
import pytest

import distlab
from distlab import gap, kelvin
from distlab.client import ServiceError
from conftest import EXE, ROOT, assert_same, run_cli


@pytest.fixture(scope="module")
def server(exe):
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as web:
        proc = subprocess.Popen([exe, "serve", "--host", "127.0.0.1", "--port", "0", "--cache-dir", cache,
                                 "--web", web, "--assets", str(ROOT / "assets"), "--threads", "2"],
                                stdout=subprocess.PIPE, text=True)
        line = proc.stdout.readline()  # "... 127.0.0.1:PORT ...": the port it got
        m = re.search(r"127\.0\.0\.1:(\d+)", line)
        assert m, line
        url = f"http://127.0.0.1:{m.group(1)}"
        try:
            for _ in range(100):
                try:
                    distlab.Client(url).health()
                    break
                except Exception:  # noqa: BLE001  (not up yet)
                    time.sleep(0.05)
            yield url
        finally:
            proc.send_signal(signal.SIGTERM)
            assert proc.wait(timeout=30) == 0


def test_gap_equals_in_process(server):
    request = json.loads((ROOT / "assets" / "gap" / "example.json").read_text())
    c = distlab.Client(server)
    assert_same(c.gap_distance(request), gap.solve(request))


def test_bad_input_names_the_field(server):
    c = distlab.Client(server)
    with pytest.raises(ServiceError) as info:
        c.gap_distance({"a": {"type": "box", "size": [1, -1, 1]}, "b": {"type": "sphere", "radius": 1}})
    assert info.value.field == "a.size[1]" and info.value.status == 400
    assert isinstance(info.value, ValueError)


def test_kelvin_object(server, tmp_path):
    c = distlab.Client(server)
    stages = []
    upload = c.upload(ROOT / "assets" / "cube.stl")
    obj = c.kelvin_object(upload=upload, lx=0.25, progress=lambda s, f: stages.append(s))
    assert obj.info()["state"] == "ready" and stages
    obj.set_sigma(constant=0.2)
    points = np.array([[1.0, 0.2, 0.1], [0.0, 0.0, 0.0], [-2.0, 1.0, 0.5]])
    h, g, inside = obj.query(points)
    # In process, the same preparation and σ give the same numbers (JSON carries doubles exactly).
    field = kelvin.Field.prepare(ROOT / "assets" / "cube.stl", lx=0.25)
    field.set_sigma(constant=0.2)
    h2, g2, status = field.query(points)
    np.testing.assert_array_equal(h, h2)
    np.testing.assert_array_equal(g, g2)
    np.testing.assert_array_equal(inside, status == kelvin.INSIDE)
    V, F = obj.isosurface(0.3)
    assert V.dtype == np.float32 and F.dtype == np.uint32 and F.max() < len(V)
    V2, F2 = field.isosurface(0.3)
    assert len(V) == len(V2) and len(F) == len(F2)
    obj.export(tmp_path / "iso.stl", 0.3)
    assert (tmp_path / "iso.stl").stat().st_size == 84 + 50 * len(F)
    surface = obj.surface()
    np.testing.assert_allclose(surface["scalars"], 0.2, rtol=0, atol=1e-6)


def test_cbf_rollout_streams_every_step(server):
    c = distlab.Client(server)
    params = {"duration": 0.5}
    frames = list(c.cbf_rollout("corridor", "gap", params, batch_steps=7))
    assert [f["i"] for f in frames] == list(range(len(frames)))
    record = distlab.cbf.rollout("corridor", "gap", params)
    assert len(frames) == len(record["t"])
    np.testing.assert_array_equal(np.array([f["q"] for f in frames]), record["q"])
    np.testing.assert_array_equal(np.array([f["u"] for f in frames]), record["u"])


def test_cbf_sweep_equals_in_process(server):
    c = distlab.Client(server)
    events = []
    values = [0.002, 0.0005, 0.0002]
    sweep = c.cbf_sweep("corridor", "margins.gap.obstacle", values, params={"duration": 0.5},
                        progress=lambda stage, f: events.append((stage, f)))
    status = sweep.status()
    assert status["job"]["state"] == "succeeded" and status["job"]["kind"] == "cbf_sweep"
    assert sweep.progress() == ("3 of 3 runs done", 1.0)
    stages = [stage for stage, _ in events if stage]  # "" while the job is queued
    assert stages and all(stage.endswith(" of 3 runs done") for stage in stages)
    ours = distlab.cbf.sweep("corridor", "margins.gap.obstacle", values, params={"duration": 0.5})
    assert_same(sweep.result(), ours, skip={"step_us_mean"})


def test_cbf_sweep_entries_keep_the_sweeps_order(server):
    # Run 1 is the shortest and finishes first; the entries stay in the order of the values.
    result = distlab.Client(server).cbf_sweep("corridor", "duration", [1.0, 0.1, 0.5],
                                              params={"record_pairs": False}).result()
    assert [(e["index"], e["value"], e["steps"]) for e in result["entries"]] == [(0, 1.0, 100), (1, 0.1, 10), (2, 0.5, 50)]


def test_cbf_sweep_cancel_keeps_the_finished_runs(server):
    c = distlab.Client(server)
    with pytest.raises(ServiceError) as info:
        c.cbf_sweep("corridor", "duration", [0.2, -1])
    assert info.value.field == "sweep.values[1]" and info.value.status == 400
    # A short run, then two of 150 s: cancelled while they run.
    sweep = c.cbf_sweep("corridor", "duration", [0.2, 150, 150], params={"record_pairs": False}, wait=False)
    for _ in range(6000):
        stage, fraction = sweep.progress()
        if stage.startswith("1 of 3") and fraction > 0.05:
            break
        time.sleep(0.01)
    else:
        pytest.fail(f"the sweep did not advance: {sweep.status()['job']}")
    sweep.cancel()
    with pytest.raises(ServiceError) as info:
        sweep.wait()
    assert info.value.code == "cancelled"
    result = sweep.result()
    assert [(e["index"], e["value"], e["steps"]) for e in result["entries"]] == [(0, 0.2, 20)]


def root_base(a):
    while isinstance(a, np.ndarray):
        a = a.base
    return a


def test_graded_object_is_the_in_process_graded_field(server):
    # grading reaches the server's preparation: the same mesh as Field.prepare with it.
    c = distlab.Client(server)
    obj = c.kelvin_object(asset="cube", lx=0.2, grading=0.05)
    local = kelvin.Field.prepare(ROOT / "assets" / "cube.stl", lx=0.2, grading=0.05).stats
    assert obj.info()["stats"]["n_verts"] == local["n_verts"]
    assert obj.info()["stats"]["grading"] == local["grading"] == 0.05
    assert obj.info()["stats"]["n_verts"] != kelvin.Field.prepare(ROOT / "assets" / "cube.stl", lx=0.2).stats["n_verts"]


def test_sigma_edits_over_the_websocket(server):
    c = distlab.Client(server)
    obj = c.kelvin_object(asset="cube", lx=0.25)
    levels = [0.3, 0.5]
    with c.live() as live:
        live.watch(obj, levels)
        v1 = live.set_sigma(obj, constant=0.1)
        v2 = live.set_sigma(obj, constant=0.2)
        assert v2 == v1 + 1
        frames = live.isosurfaces(obj, v2)
        assert sorted(frames) == levels
        # Each pushed frame is the REST iso-surface of the same σ, and the in-process field's
        # (float32 of its doubles); its arrays view the received message (no copy).
        field = kelvin.Field.prepare(ROOT / "assets" / "cube.stl", lx=0.25)
        field.set_sigma(constant=0.2)
        for level, frame in frames.items():
            V, F = obj.isosurface(level)
            np.testing.assert_array_equal(frame["positions"], V)
            np.testing.assert_array_equal(frame["indices"], F)
            V2, F2 = field.isosurface(level)
            np.testing.assert_array_equal(frame["positions"], V2.astype(np.float32))
            np.testing.assert_array_equal(frame["indices"], F2)
            assert isinstance(root_base(frame["positions"]), bytes)
            assert root_base(frame["positions"]) is root_base(frame["indices"])
        # A bad σ is refused over the socket too, naming the field.
        with pytest.raises(ServiceError) as info:
            live.set_sigma(obj, per_vertex=[0.1, 0.2])
        assert info.value.field.startswith("sigma.per_vertex") or info.value.field.startswith("per_vertex")


def test_mesh_frames_decode_without_copies(server):
    c = distlab.Client(server)
    obj = c.kelvin_object(asset="cube", lx=0.25, sigma={"constant": 0.3})
    data = c._request("GET", obj._path("/surface"), raw=True)
    frame = distlab.client.decode_mesh_frame(data)
    assert root_base(frame["positions"]) is data and root_base(frame["scalars"]) is data
    assert not frame["positions"].flags.writeable
    V, F = kelvin.Field.prepare(ROOT / "assets" / "cube.stl", lx=0.25).surface
    np.testing.assert_array_equal(frame["positions"], V.astype(np.float32))
    np.testing.assert_array_equal(frame["indices"], F)
    np.testing.assert_array_equal(frame["scalars"], np.float32(0.3))


# A unit cube of polygons whose defect is at a known face of the file: faces 0-4 are quads
# (triangles 0-9), face 5 (top) a hexagon (4, q, m, 5, 6, 7) through the points q and m of its
# front edge (triangles 10-13), and face 6 the quad (4, 5, m, q) on that edge: no area, so it stays
# the fan around its first corner, whose first triangle (4, 5, m) is triangle 14, face 6 of the file.
POLYGON_CUBE_VERTICES = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (1, 1, 1), (0, 1, 1),
                         (0.5, 0, 1), (0.25, 0, 1)]
POLYGON_CUBE_FACES = [(0, 3, 2, 1), (3, 7, 6, 2), (0, 4, 7, 3), (1, 2, 6, 5), (0, 1, 5, 4), (4, 9, 8, 5, 6, 7),
                      (4, 5, 8, 9)]
DEGENERATE_FACE = "degenerate (zero-area) face 6 (triangle 0 of its 4-corner polygon)"


def polygon_cube(fmt):
    if fmt == "obj":
        return "".join(f"v {x} {y} {z}\n" for x, y, z in POLYGON_CUBE_VERTICES) + "".join(
            "f " + " ".join(str(i + 1) for i in f) + "\n" for f in POLYGON_CUBE_FACES)
    return (f"OFF\n{len(POLYGON_CUBE_VERTICES)} {len(POLYGON_CUBE_FACES)} 0\n"
            + "".join(f"{x} {y} {z}\n" for x, y, z in POLYGON_CUBE_VERTICES)
            + "".join(f"{len(f)} " + " ".join(map(str, f)) + "\n" for f in POLYGON_CUBE_FACES))


@pytest.mark.parametrize("fmt", ["obj", "off"])
def test_polygon_file_refusals_name_the_files_face(server, fmt, tmp_path):
    # Through the HTTP upload (the import runs in a child process).
    c = distlab.Client(server)
    upload = c.upload(polygon_cube(fmt).encode(), fmt)
    with pytest.raises(ServiceError) as info:
        c.kelvin_object(upload=upload, lx=0.3, wait=False)
    assert DEGENERATE_FACE in str(info.value), str(info.value)
    # Through the CLI.
    path = tmp_path / f"cube.{fmt}"
    path.write_text(polygon_cube(fmt))
    code, answer = run_cli("kelvin", {"mesh": {"path": str(path)}, "lx": 0.3})
    assert code == 2, answer
    assert DEGENERATE_FACE in answer["error"]["message"], answer


def lat_long_sphere(n):
    """The unit sphere on n rings of 2n points and two poles: 4 n (n - 1) + 4 n faces, closed."""
    rings = [(np.sin(t) * np.cos(p), np.sin(t) * np.sin(p), np.cos(t))
             for t in np.pi * np.arange(1, n + 1) / (n + 1) for p in np.pi * np.arange(2 * n) / n]
    V = np.array([(0, 0, 1)] + rings + [(0, 0, -1)], float)
    at = lambda i, j: 1 + i * 2 * n + j % (2 * n)  # noqa: E731
    F = [(0, at(0, j), at(0, j + 1)) for j in range(2 * n)]
    F += [f for i in range(n - 1) for j in range(2 * n)
          for f in ((at(i, j), at(i + 1, j), at(i + 1, j + 1)), (at(i, j), at(i + 1, j + 1), at(i, j + 1)))]
    F += [(len(V) - 1, at(n - 1, j + 1), at(n - 1, j)) for j in range(2 * n)]
    return V, np.array(F)


def test_simplify_and_delete_an_upload(server):
    # A 1,600-face sphere simplified to 200 faces: the object reports the reduction; a deleted
    # upload is gone (404 naming id).
    c = distlab.Client(server)
    V, F = lat_long_sphere(20)
    assert len(F) == 1600
    obj = c.kelvin_object(mesh=(V, F), lx_fraction=0.2, simplify=200, components="largest")
    info = obj.info()
    assert info["state"] == "ready"
    assert info["simplify_report"]["n_input_faces"] == len(F) and info["simplify_report"]["n_faces"] <= 200
    assert info["components_report"]["pieces"] == 1
    with pytest.raises(ServiceError) as bad:
        c.kelvin_object(mesh=(V, F), lx_fraction=0.2, simplify=2)
    assert bad.value.field == "simplify.faces"
    upload = c.upload(ROOT / "assets" / "cube.stl")
    c.delete_upload(upload)
    with pytest.raises(ServiceError) as gone:
        c.delete_upload(upload)
    assert gone.value.status == 404 and gone.value.field == "id"
