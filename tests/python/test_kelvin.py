"""distlab.kelvin against the CLI (bit for bit), the sphere's closed form, and bad input."""

import os

import numpy as np
import pytest

import distlab
from distlab import kelvin
from conftest import ROOT, assert_same, run_cli

SPHERE = str(ROOT / "assets" / "sphere.stl")  # radius 0.5 at the origin


def test_solve_equals_cli(exe, tmp_path):
    request = {"mesh": {"asset": "cube"}, "lx": 0.25, "sigma": {"constant": 0.2},
               "query": [[1.0, 0.2, 0.1], [0.0, 0.0, 0.0], [0.6, 0.6, 0.7], [-2.0, 1.0, 0.5]]}
    code, cli = run_cli("kelvin", request)
    assert code == 0, cli
    ours = kelvin.solve(request)
    assert_same(ours, cli, skip={"t_mesh", "t_build", "t_decomp", "t_solve", "size_mb"})
    assert np.isnan(ours["query"]["h"][1])  # inside: null in JSON


def test_grading_reaches_the_mesher_through_cli_and_binding(exe):
    # The graded sizing (grading > 0) through the CLI request and through Field.prepare: the same
    # mesh, and not the paper's sizing's.
    request = {"mesh": {"asset": "cube"}, "lx": 0.12, "grading": 0.05}
    code, cli = run_cli("kelvin", request)
    assert code == 0, cli
    cube = str(ROOT / "assets" / "cube.stl")
    graded = kelvin.Field.prepare(cube, lx=0.12, grading=0.05).stats
    paper = kelvin.Field.prepare(cube, lx=0.12).stats
    assert cli["stats"]["n_verts"] == graded["n_verts"] and cli["stats"]["n_tets"] == graded["n_tets"]
    assert graded["n_verts"] != paper["n_verts"]
    # Stats say which sizing was meshed; not given, a field this coarse gets eq. 23's.
    assert cli["stats"]["grading"] == 0.05 and graded["grading"] == 0.05 and paper["grading"] == 0


def test_mesh_threads_reach_the_mesher_through_cli_and_binding(exe):
    # mesh_threads 1 is reproducible: the CLI and the binding make the same mesh and the same h,
    # bit for bit. 2 meshes in parallel (another mesh each run), says so, and answers within the
    # mesh's accuracy. Bad values: BAD below.
    point = [[1.0, 0.2, 0.1]]
    request = {"mesh": {"asset": "cube"}, "lx": 0.15, "mesh_threads": 1, "query": point}
    code, cli = run_cli("kelvin", request)
    assert code == 0, cli
    cube = str(ROOT / "assets" / "cube.stl")
    one = kelvin.Field.prepare(cube, lx=0.15, mesh_threads=1)
    assert cli["stats"]["mesh_threads"] == 1 and one.stats["mesh_threads"] == 1
    assert cli["stats"]["n_verts"] == one.stats["n_verts"] and cli["stats"]["n_tets"] == one.stats["n_tets"]
    assert one.query(point)[0][0] == cli["query"]["h"][0]
    two = kelvin.Field.prepare(cube, lx=0.15, mesh_threads=2)
    assert two.stats["mesh_threads"] == 2
    assert abs(two.stats["n_verts"] - one.stats["n_verts"]) <= 0.1 * one.stats["n_verts"]
    assert abs(two.query(point)[0][0] - one.query(point)[0][0]) < 0.02
    assert not any("child process" in w for w in two.stats["warnings"]), two.stats["warnings"]


def test_mesh_threads_mesh_in_a_child_that_may_crash(tmp_path, monkeypatch):
    # mesh_threads > 1 meshes in a child process (the distlab program), so a crash of CGAL's
    # parallel refinement there costs a new child, then one thread, never this process. A stand-in
    # child that always crashes: two children, then the same field as one thread's, said in warnings.
    runs = tmp_path / "runs"
    crashing = tmp_path / "crashing"
    crashing.write_text(f"#!/bin/sh\necho run >> '{runs}'\nkill -SEGV $$\n")
    crashing.chmod(0o755)
    monkeypatch.setattr(kelvin, "_mesh_worker", lambda: str(crashing))
    cube = str(ROOT / "assets" / "cube.stl")
    one = kelvin.Field.prepare(cube, lx=0.15, mesh_threads=1)
    two = kelvin.Field.prepare(cube, lx=0.15, mesh_threads=2)
    assert runs.read_text().count("run") == 2
    assert two.stats["mesh_threads"] == 1
    assert two.stats["n_verts"] == one.stats["n_verts"] and two.stats["n_tets"] == one.stats["n_tets"]
    warnings = two.stats["warnings"]
    assert any("signal 11" in w and "in a new child" in w for w in warnings), warnings
    assert any("signal 11" in w and "meshed again on one thread" in w for w in warnings), warnings
    solved = kelvin.solve({"mesh": {"asset": "cube"}, "lx": 0.15, "mesh_threads": 2})
    assert runs.read_text().count("run") == 4
    assert solved["stats"]["mesh_threads"] == 1 and solved["stats"]["n_verts"] == one.stats["n_verts"]
    # The program beside the package is the worker by default.
    monkeypatch.undo()
    assert kelvin._mesh_worker() == distlab.executable() and os.access(distlab.executable(), os.X_OK)


@pytest.fixture(scope="module")
def sphere_field():
    # Inversion centre off the sphere's centre, so V is not trivially exact (as in the C++ test).
    return kelvin.Field.prepare(SPHERE, lx=0.15, center=[0.1, -0.05, 0.08])


def test_sphere_matches_closed_form(sphere_field):
    sigma = 0.3
    sphere_field.set_sigma(constant=sigma)
    rng = np.random.default_rng(2)
    d = rng.standard_normal((500, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    r = rng.uniform(0.6, 2.0, (500, 1))
    x = d * r
    h, g, status = sphere_field.query(x)
    assert (status == 0).all()
    exact = sigma + np.log(r[:, 0] / 0.5)  # h = σ + ln(|x| / R)
    np.testing.assert_allclose(h, exact, atol=0.03)
    np.testing.assert_allclose(g, d / r, atol=0.15)
    h_nohint, g_nohint, _ = sphere_field.query(x, hints=False)
    np.testing.assert_array_equal(h_nohint, h)
    np.testing.assert_array_equal(g_nohint, g)
    _, _, inside = sphere_field.query([[0.0, 0.0, 0.0]])
    assert inside[0] == kelvin.INSIDE


def test_isosurface_and_export(sphere_field, tmp_path):
    sphere_field.set_sigma(constant=0.3)
    V, F = sphere_field.isosurface(0.5)
    radii = np.linalg.norm(V, axis=1)
    np.testing.assert_allclose(radii, 0.5 * np.exp(0.2), rtol=0.05)  # σ + ln(r/R) = 0.5
    assert F.shape[1] == 3 and F.max() < len(V)
    path = tmp_path / "iso.stl"
    check = sphere_field.export(path, 0.5)
    assert path.stat().st_size == 84 + 50 * len(F)
    assert check["closed"] and check["manifold"] and check["components"] == 1
    np.testing.assert_allclose(check["volume"], 4 / 3 * np.pi * (0.5 * np.exp(0.2)) ** 3, rtol=0.05)
    # The level σ itself is the object's surface: closed too, by a count of our own on the file's
    # float32 corners (every edge in exactly two triangles).
    check = sphere_field.export(path, 0.3)
    corners = np.fromfile(path, dtype=np.dtype([("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")]), offset=84)["v"]
    _, ids = np.unique(corners.reshape(-1, 3), axis=0, return_inverse=True)
    tri = ids.reshape(-1, 3)
    edges = np.sort(np.concatenate([tri[:, [0, 1]], tri[:, [1, 2]], tri[:, [2, 0]]]), axis=1)
    _, uses = np.unique(edges, axis=0, return_counts=True)
    assert set(uses.tolist()) == {2} and check["manifold"]
    np.testing.assert_allclose(check["volume"], 4 / 3 * np.pi * 0.5 ** 3, rtol=0.05)  # chords of the meshed sphere


def test_per_vertex_sigma_follows_the_surface(sphere_field):
    V, _ = sphere_field.surface
    sphere_field.set_sigma(per_vertex=np.full(len(V), 0.3))
    h1, _, _ = sphere_field.query([[1.0, 0.0, 0.0]])
    sphere_field.set_sigma(constant=0.3)
    h2, _, _ = sphere_field.query([[1.0, 0.0, 0.0]])
    np.testing.assert_allclose(h1, h2, rtol=0, atol=1e-12)


def test_prepare_from_arrays_and_cache(tmp_path):
    V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float) - 0.5
    F = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                  [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])
    stages = []
    f1 = kelvin.Field.prepare((V, F), lx=0.3, cache_dir=tmp_path, progress=lambda s, f: stages.append(s))
    assert stages and not f1.stats["cache_hit"]
    f2 = kelvin.Field.prepare((V, F), lx=0.3, cache_dir=tmp_path)
    assert f2.stats["cache_hit"]
    x = [[1.0, 0.3, 0.2]]
    assert f1.query(x)[0][0] == f2.query(x)[0][0]


CUBE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float) - 0.5
CUBE_F = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                   [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])


def test_prepare_takes_the_services_unit_components_simplify_and_repair():
    # unit: the mesh in millimetres is the metre cube.
    mm = kelvin.Field.prepare((CUBE_V * 1000, CUBE_F), lx=0.3, unit="mm")
    V, _ = mm.surface
    np.testing.assert_allclose(np.abs(V).max(), 0.5)
    assert kelvin.Field.prepare((CUBE_V * 2, CUBE_F), lx=0.3, scale=0.5).surface[0].max() == 0.5
    # components: a small cube beside the big one is an obstacle with "all" and gone with "largest".
    two = (np.vstack([CUBE_V, 0.2 * CUBE_V + [1.5, 0, 0]]), np.vstack([CUBE_F, CUBE_F + 8]))
    inside_small = [[1.5, 0.0, 0.0]]
    both = kelvin.Field.prepare(two, lx=0.3)
    assert both.query(inside_small)[2][0] == kelvin.INSIDE
    largest = kelvin.Field.prepare(two, lx=0.3, components="largest")
    h, _, status = largest.query(inside_small)
    assert status[0] == 0 and h[0] > 0
    assert largest.stats["components"]["pieces"] == 2 and len(largest.surface[0]) == 8
    # simplify: a 5120-face sphere to at most 500 faces, its distance reported.
    sphere = kelvin.Field.prepare(SPHERE, lx=0.2, simplify=500)
    assert len(sphere.surface[1]) <= 500 < sphere.stats["simplify"]["n_input_faces"]
    assert 0 < sphere.stats["simplify"]["hausdorff"]["input_to_simplified"] < 0.05
    # repair: the cube with one face missing is refused as it is and prepared by "fix".
    with pytest.raises(distlab.InvalidInput):
        kelvin.Field.prepare((CUBE_V, CUBE_F[:-1]), lx=0.3)
    fixed = kelvin.Field.prepare((CUBE_V, CUBE_F[:-1]), lx=0.3, repair="fix", repair_options={"max_hole_edges": 3})
    assert fixed.stats["repair"]["kind"] == "fix" and len(fixed.surface[1]) == 12
    # the CLI's request reads the same keys.
    out = kelvin.solve({"mesh": {"asset": "cube"}, "lx": 0.3, "components": "largest"})
    assert out["components"]["pieces"] == 1


def test_an_exception_in_progress_cancels():
    class Stop(Exception):
        pass

    def progress(stage, fraction):
        raise Stop()

    with pytest.raises(Stop):
        kelvin.Field.prepare(SPHERE, lx=0.05, progress=progress)


def test_strokes_by_the_boundary_response_equal_strokes_by_the_factor():
    field = kelvin.Field.prepare(SPHERE, lx=0.15, center=[0.1, -0.05, 0.08])
    points = np.array([[0.7, 0.1, 0.0], [0.0, -0.8, 0.3], [0.4, 0.4, -0.6], [-1.5, 0.2, 0.2]])
    stroke = [{"center": [0.5, 0.0, 0.0], "radius": 0.15, "value": 0.8, "falloff": 0.05}]

    def paint():
        field.set_sigma(constant=0.4)  # another σ: the next one is solved in full
        field.set_sigma(constant=0.1)
        field.set_sigma(constant=0.1, brushes=stroke)  # the stroke, by linearity
        assert field.stats["linear_boundary"] > 0
        return field.query(points)[0]

    by_factor = paint()
    assert field.stats["response_mb"] == 0 and not field.stats["linear_by_response"]
    assert not field.build_boundary_response(max_megabytes=1e-3)
    assert field.build_boundary_response()
    assert 0 < field.stats["response_mb"] < field.stats["size_mb"]
    by_response = paint()
    assert field.stats["linear_by_response"]
    np.testing.assert_allclose(by_response, by_factor, rtol=1e-12, atol=0)
    assert np.abs(by_response - paint()).max() == 0  # the same strokes, the same field
    with pytest.raises(distlab.InvalidInputType) as info:
        field.build_boundary_response(max_megabytes="a")
    assert info.value.field == "max_megabytes"


BAD = [
    (lambda: kelvin.Field.prepare(SPHERE, lx=-1), distlab.InvalidInput, "lx"),
    (lambda: kelvin.Field.prepare(SPHERE, lx="a"), distlab.InvalidInputType, "lx"),
    (lambda: kelvin.Field.prepare("/nonexistent.stl", lx=0.1), distlab.InvalidInput, "path"),
    (lambda: kelvin.Field.prepare((np.zeros((3, 3)), [[0, 1, 5]]), lx=0.1), distlab.InvalidInput, "faces[0]"),
    (lambda: kelvin.Field.prepare((np.zeros((3, 2)), [[0, 1, 2]]), lx=0.1), distlab.InvalidInput, "vertices"),
    (lambda: kelvin.Field.prepare(SPHERE, lx=0.2, center=[0, 0]), distlab.InvalidInput, "center"),
    (lambda: kelvin.Field.prepare(SPHERE, lx=0.2, grading=-0.1), distlab.InvalidInput, "grading"),
    (lambda: kelvin.Field.prepare(SPHERE, lx=0.2, grading=float("nan")), distlab.InvalidInput, "grading"),
    (lambda: kelvin.Field.prepare(SPHERE, lx=0.2, grading="a"), distlab.InvalidInputType, "grading"),
    (lambda: kelvin.solve({"mesh": {"asset": "cube"}, "lx": 0.1, "grading": 2}), distlab.InvalidInput, "grading"),
    (lambda: kelvin.Field.prepare(SPHERE, lx=0.2, mesh_threads=-1), distlab.InvalidInput, "mesh_threads"),
    (lambda: kelvin.Field.prepare(SPHERE, lx=0.2, mesh_threads=1.5), distlab.InvalidInput, "mesh_threads"),
    (lambda: kelvin.solve({"mesh": {"asset": "cube"}, "lx": 0.1, "mesh_threads": 257}), distlab.InvalidInput, "mesh_threads"),
    (lambda: kelvin.solve({"mesh": {"asset": "nope"}, "lx": 0.1}), distlab.InvalidInput, "mesh.asset"),
    (lambda: kelvin.solve({"mesh": {"asset": "cube"}, "lx": 0.1, "extra": 1}), distlab.InvalidInput, "extra"),
    (lambda: kelvin.Field.prepare(SPHERE, lx=0.2, unit="ft"), distlab.InvalidInput, "unit"),
    (lambda: kelvin.Field.prepare(SPHERE, lx=0.2, unit="mm", scale=2), distlab.InvalidInput, "scale"),
    (lambda: kelvin.Field.prepare(SPHERE, lx=0.2, components="some"), distlab.InvalidInput, "components"),
    (lambda: kelvin.Field.prepare(SPHERE, lx=0.2, simplify=2), distlab.InvalidInput, "simplify.faces"),
    (lambda: kelvin.Field.prepare(SPHERE, lx=0.2, repair="glue"), distlab.InvalidInput, "repair"),
]


@pytest.mark.parametrize("call,error,field", BAD)
def test_bad_input_raises_naming_the_field(call, error, field):
    with pytest.raises(error) as info:
        call()
    assert info.value.field == field, str(info.value)


def test_bad_sigma_raises_naming_the_field(sphere_field):
    with pytest.raises(distlab.InvalidInput) as info:
        sphere_field.set_sigma(per_vertex=[0.1, 0.2])
    assert info.value.field.startswith("sigma.per_vertex")
    with pytest.raises(distlab.InvalidInput) as info:
        sphere_field.query([[np.nan, 0, 0]])
    assert info.value.field == "points[0]"
