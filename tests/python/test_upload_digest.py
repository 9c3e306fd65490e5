"""distlab.Client's upload routes by digest against the real `distlab serve`: reuse_upload (POST
/api/kelvin/uploads/reuse), upload_surface and upload_defects (GET /api/kelvin/uploads/ID/surface,
.../defects) as numpy arrays, and upload(..., digest=). The defects are checked against the file's
own faces counted here, their geometry against the file's vertices in metres."""

import collections
import warnings

import numpy as np
import pytest

import distlab
from distlab.client import ServiceError
from conftest import serving

# A closed tetrahedron in metres, outward faces: volume 1/6.
TETRA_V = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
TETRA_F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])

# In millimetres, every defect once: three faces on the edge 0-1 (non-manifold), a face repeating
# a vertex (degenerate), and two triangles crossing (a vertical one through the flat one at (42, 2, 0)).
DEFECT_V = np.array([[0, 0, 0], [10, 0, 0], [0, 10, 0], [0, 0, 10], [0, 0, -10],
                     [20, 0, 0], [30, 0, 0],
                     [40, 0, 0], [50, 0, 0], [40, 10, 0],
                     [42, 2, -5], [42, 2, 5], [48, 3, 0]], float)
DEFECT_F = np.array([[0, 1, 2], [1, 0, 3], [0, 1, 4], [5, 5, 6], [7, 8, 9], [10, 11, 12]])


def obj(V, F) -> bytes:
    return ("".join(f"v {x:.17g} {y:.17g} {z:.17g}\n" for x, y, z in V) +
            "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F)).encode()


def edge_uses(F):
    """How many faces use each edge (sorted vertex pair), faces that repeat a vertex left out."""
    uses = collections.Counter()
    for f in F:
        if len(set(f)) == 3:
            for i in range(3):
                uses[tuple(sorted((int(f[i]), int(f[(i + 1) % 3]))))] += 1
    return uses


@pytest.fixture(scope="module")
def server(exe):
    with serving(exe, "--threads", "2") as url:
        yield url


def test_surface_and_defects_are_the_files_in_metres(server):
    c = distlab.Client(server)
    up = c.upload(obj(DEFECT_V, DEFECT_F), "obj", unit="mm")
    metres = (DEFECT_V * 0.001).astype(np.float32)

    s = c.upload_surface(up)
    assert (s["type"], s["of"], s["upload"]) == ("surface", "upload", up)
    assert s["positions"].dtype == np.float32 and s["indices"].dtype == np.uint32
    np.testing.assert_array_equal(s["positions"], metres)  # the file's vertices in its order, in metres
    np.testing.assert_array_equal(s["indices"], DEFECT_F)

    d = c.upload_defects(up)
    uses = edge_uses(DEFECT_F)
    boundary = sorted(e for e, n in uses.items() if n == 1)
    non_manifold = sorted(e for e, n in uses.items() if n > 2)
    assert d["counts"] == {"boundary_edges": len(boundary), "non_manifold_edges": len(non_manifold),
                           "non_manifold_vertices": 0, "degenerate_faces": 1, "self_intersections": 1,
                           "components": 4}
    assert d["boundary_edges"].dtype == np.int64 and d["boundary_edges"].shape == (len(boundary), 2)
    assert sorted(map(tuple, d["boundary_edges"].tolist())) == boundary
    np.testing.assert_array_equal(d["non_manifold_edges"], non_manifold)
    np.testing.assert_array_equal(d["degenerate_faces"], [3])
    np.testing.assert_array_equal(d["self_intersections"], [[4, 5]])
    assert d["non_manifold_vertices"].shape == (0,) and not d["truncated"] and d["self_intersections_complete"]
    # The pieces in order of their first face: the fins, the degenerate face, the two crossing ones.
    assert [(p["faces"], p["runs"].tolist()) for p in d["components"]] == [(3, [[0, 3]]), (1, [[3, 1]]), (1, [[4, 1]]),
                                                                          (1, [[5, 1]])]

    g = d["geometry"]
    np.testing.assert_array_equal(g["boundary_edges"], metres[d["boundary_edges"]])
    assert g["boundary_edges"].shape == (len(boundary), 2, 3)
    np.testing.assert_array_equal(g["non_manifold_edges"], [[metres[0], metres[1]]])
    np.testing.assert_array_equal(g["degenerate_faces"], [metres[[5, 5, 6]]])
    np.testing.assert_array_equal(g["self_intersections"], [[metres[[7, 8, 9]], metres[[10, 11, 12]]]])
    assert g["non_manifold_vertices"].shape == (0, 3)
    assert "geometry" not in c.upload_defects(up, geometry=False)


def test_a_closed_mesh_has_no_defects_and_its_volume(server):
    c = distlab.Client(server)
    up = c.upload(obj(TETRA_V, TETRA_F), "obj")
    d = c.upload_defects(up)
    assert d["counts"] == {"boundary_edges": 0, "non_manifold_edges": 0, "non_manifold_vertices": 0,
                           "degenerate_faces": 0, "self_intersections": 0, "components": 1}
    assert d["largest_component"] == 0 and d["components"][0]["faces"] == 4
    assert d["components"][0]["volume"] == pytest.approx(1 / 6, rel=1e-12)
    # Empty lists keep their shapes, so that they index and stack like full ones.
    assert {k: d[k].shape for k in ("boundary_edges", "non_manifold_edges", "non_manifold_vertices", "degenerate_faces",
                                    "self_intersections")} == {
        "boundary_edges": (0, 2), "non_manifold_edges": (0, 2), "non_manifold_vertices": (0,), "degenerate_faces": (0,),
        "self_intersections": (0, 2)}
    assert {k: v.shape for k, v in d["geometry"].items()} == {
        "boundary_edges": (0, 2, 3), "non_manifold_edges": (0, 2, 3), "non_manifold_vertices": (0, 3),
        "degenerate_faces": (0, 3, 3), "self_intersections": (0, 2, 3, 3)}


def test_lists_stop_at_max_defect_items_and_counts_stay_whole(exe):
    # A flat 4 x 4 grid of squares: 16 open edges on its rim, above a limit of 5 items.
    n = 4
    V = np.array([[i, j, 0] for j in range(n + 1) for i in range(n + 1)], float)
    F = [[j * (n + 1) + i, j * (n + 1) + i + 1, (j + 1) * (n + 1) + i + 1] for j in range(n) for i in range(n)] + \
        [[j * (n + 1) + i, (j + 1) * (n + 1) + i + 1, (j + 1) * (n + 1) + i] for j in range(n) for i in range(n)]
    rim = sorted(e for e, k in edge_uses(F).items() if k == 1)
    assert len(rim) == 4 * n
    with serving(exe, "--threads", "1", "--limit", "max_defect_items=5") as url:
        c = distlab.Client(url)
        d = c.upload_defects(c.upload(obj(V, F), "obj"))
    assert d["max_items"] == 5 and d["truncated"]
    assert d["counts"]["boundary_edges"] == len(rim)
    assert d["boundary_edges"].shape == (5, 2) and set(map(tuple, d["boundary_edges"].tolist())) <= set(rim)
    np.testing.assert_array_equal(d["geometry"]["boundary_edges"], V.astype(np.float32)[d["boundary_edges"]])


def test_reuse_gives_the_same_mesh_to_another_session(server):
    a, b = distlab.Client(server), distlab.Client(server)
    first = a.upload(obj(DEFECT_V, DEFECT_F), "obj", unit="mm", info=True)
    again = b.reuse_upload(first["digest"], info=True)
    assert again["reused"] is True and again["upload"] != first["upload"]
    assert {k: v for k, v in again.items() if k not in ("upload", "reused")} == \
           {k: v for k, v in first.items() if k != "upload"}
    sa, sb = a.upload_surface(first["upload"]), b.upload_surface(again["upload"])
    np.testing.assert_array_equal(sb["positions"], sa["positions"])
    np.testing.assert_array_equal(sb["indices"], sa["indices"])
    assert sb["digest"] == first["digest"]
    da, db = a.upload_defects(first["upload"]), b.upload_defects(again["upload"])
    np.testing.assert_array_equal(db["boundary_edges"], da["boundary_edges"])
    np.testing.assert_array_equal(db["geometry"]["self_intersections"], da["geometry"]["self_intersections"])
    # The other session's id is not this one's: a reuse gives the mesh, not the upload.
    with pytest.raises(ServiceError) as info:
        b.upload_surface(first["upload"])
    assert (info.value.status, info.value.code, info.value.field) == (404, "unknown_upload", "id")


def test_an_object_from_a_reused_upload_is_of_that_mesh(server):
    a, b = distlab.Client(server), distlab.Client(server)
    digest = a.upload(obj(TETRA_V, TETRA_F), "obj", info=True)["digest"]
    o = b.kelvin_object(upload=b.reuse_upload(digest), lx_fraction=0.3)
    assert o.info()["surface_digest"] == digest


def test_digest_refusals_name_the_field(server):
    a, c = distlab.Client(server), distlab.Client(server)
    tetra = obj(TETRA_V * 2, TETRA_F)  # a mesh no other test holds
    up = a.upload(tetra, "obj", info=True)
    digest = up["digest"]
    cases = [
        ("abc", 400, "invalid_input"),
        (digest.upper(), 400, "invalid_input"),  # the API's digests are lower-case hex
        (digest[:-1] + ("0" if digest[-1] != "0" else "1"), 404, "upload_not_held"),
    ]
    for bad, status, code in cases:
        with pytest.raises(ServiceError) as info:
            c.reuse_upload(bad)
        assert (info.value.status, info.value.code, info.value.field) == (status, code, "digest"), bad
    with pytest.raises(distlab.InvalidInputType) as wrong_type:
        c.reuse_upload(bytes.fromhex(digest))
    assert wrong_type.value.field == "digest"
    # upload(digest=): the same file passes, another mesh or the same file in another unit does not.
    checked = c.upload(tetra, "obj", digest=digest, info=True)
    assert checked["digest"] == digest
    for data, unit in ((obj(TETRA_V * 3, TETRA_F), None), (tetra, "mm")):
        with pytest.raises(ServiceError) as info:
            c.upload(data, "obj", unit=unit, digest=digest)
        assert (info.value.status, info.value.code, info.value.field) == (422, "different_mesh", "body")
    # Held while a session holds it: once every holder deleted it, it is gone.
    a.delete_upload(up["upload"])
    c.delete_upload(checked["upload"])
    with pytest.raises(ServiceError) as info:
        distlab.Client(server).reuse_upload(digest)
    assert (info.value.status, info.value.code, info.value.field) == (404, "upload_not_held", "digest")


def test_unknown_upload_ids_name_the_field(server):
    c = distlab.Client(server)
    for bad in ("0123456789abcdef0123456789abcdef", "../objects", "a?b=c"):
        for call in (c.upload_surface, c.upload_defects):
            with pytest.raises(ServiceError) as info:
                call(bad)
            assert (info.value.status, info.value.code, info.value.field) == (404, "unknown_upload", "id"), bad
    with pytest.raises(distlab.InvalidInputType) as info:
        c.upload_surface(7)
    assert info.value.field == "id"


def test_a_recovered_session_reuses_the_mesh_again(server):
    a, b = distlab.Client(server), distlab.Client(server)
    digest = a.upload(obj(DEFECT_V, DEFECT_F), "obj", unit="mm", info=True)["digest"]
    mine = b.reuse_upload(digest)
    before = b.upload_surface(mine)
    b._send("DELETE", "/api/session")  # the session is lost (as when its replica stops)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        after = b.upload_surface(mine)  # the old id still names it
    assert b.recoveries == 1 and any(issubclass(w.category, RuntimeWarning) for w in caught)
    assert after["digest"] == digest and after["upload"] != mine
    np.testing.assert_array_equal(after["positions"], before["positions"])
