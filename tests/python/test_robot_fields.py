"""Kelvin fields as CBF barriers from Python (issue 33): Robot.field_barrier and
Robot.cbf_rows(fields=...) against the built-in controller's rows of the wrench_grasp scenario,
the row gradient against central differences of h(x(q)), bad input naming its field, and the
kelvin part of a distlab.cbf.rollout record.

The wrench's field is prepared once per test session (~25 s) into a temporary cache: cache_dir=
for Robot.field_barrier, $XDG_CACHE_HOME (whose distlab/ is that same folder) for the rollouts and
the controller, so nothing is written to $HOME."""

import json
import os

import numpy as np
import pytest

import distlab
from distlab import _core, cbf
from distlab.robot import Robot

SCENARIO = "wrench_grasp"


@pytest.fixture(scope="session")
def cache_dir(tmp_path_factory):
    """The session's Kelvin cache: $XDG_CACHE_HOME/distlab, XDG_CACHE_HOME a temporary folder."""
    home = tmp_path_factory.mktemp("xdg-cache")
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("XDG_CACHE_HOME", str(home))  # read by the C++ core at each preparation
        yield str(home / "distlab")


@pytest.fixture(scope="session")
def scenario():
    with open(os.path.join(distlab.assets_dir, "scenarios", f"{SCENARIO}.json")) as f:
        return json.load(f)


@pytest.fixture(scope="session")
def hand():
    return Robot.load("panda_hand")


@pytest.fixture(autouse=True)
def _temporary_cache(cache_dir):
    """Every test here, alone too, prepares into the session's cache."""


def barrier_of(hand, scenario, cache_dir, **changes):
    """A fresh FieldBarrier of the scenario's fields and control points (its cell hints unused)."""
    fields = [dict(f, **changes) for f in scenario["fields"]]
    return hand.field_barrier(fields, scenario["control_points"], cache_dir=cache_dir)


@pytest.fixture(scope="session")
def barrier(hand, scenario, cache_dir):
    return barrier_of(hand, scenario, cache_dir)  # the first one prepares the field


@pytest.fixture(scope="session")
def semantic(barrier, cache_dir):
    """The semantic run's first 6 s: the approach and the pads at the handle (≤ 2 mm at 4.2 s)."""
    return cbf.rollout(SCENARIO, "euclidean", {"duration": 6})


@pytest.fixture(scope="session")
def along(semantic):
    """A few configurations along it: far, approaching, at the handle, settled."""
    return semantic["q"][[0, 150, 300, 420, 599]]


def world_point(hand, q, link, point):
    """A link-frame point in the world at q (fk's [x, y, z, qw, qx, qy, qz])."""
    pose = hand.fk(q)[hand.links.index(link)]
    w, u = pose[3], pose[4:]
    p = np.asarray(point, float)
    t = 2 * np.cross(u, p)
    return pose[:3] + p + w * t + np.cross(u, t)


# ---------------------------------------------------------------------------------------------
# the rows


def test_cbf_rows_with_fields_equal_the_built_in_controllers(hand, scenario, cache_dir, along):
    obstacles = [dict(o["shape"], name=o["name"]) for o in scenario["obstacles"]]
    C, d, names = _core.cbf_controller_rows({"scenario": SCENARIO, "metric": "euclidean"}, along)
    fields = barrier_of(hand, scenario, cache_dir)  # fresh hints, as the controller's
    rows = hand.cbf_rows(along, obstacles, "euclidean", "both", margins=scenario["margins"]["euclidean"],
                         eta=scenario["eta"], eta_joint=scenario["eta_joint"], threads=1, fields=fields)
    A, b = rows
    P, F = len(names), len(fields.names)
    assert rows.distances.names == names
    assert F == 72 and fields.names[0] == "left_pad_face_00/wrench"
    assert any(n.endswith("/table") for n in names) and any(not n.endswith("/table") for n in names)  # and self pairs
    joint_limits = 2 * hand.dof  # every joint of the Panda and the hand is bounded
    assert A.shape == C.shape == (len(along), P + F + joint_limits, hand.dof)
    assert b.shape == d.shape == (len(along), P + F + joint_limits)
    # Pairs, field rows, joint limits: the controller's rows, bit for bit.
    np.testing.assert_array_equal(A, C)
    np.testing.assert_array_equal(b, d)
    # The field block is the barrier's: ∇_q h (smoothed) · u >= −η (h − δ).
    h, g = barrier_of(hand, scenario, cache_dir).evaluate(along)
    np.testing.assert_array_equal(A[:, P:P + F], g)
    np.testing.assert_allclose(b[:, P:P + F], -scenario["eta"] * (h - fields.margins), rtol=0, atol=1e-15)
    assert np.all(fields.margins == scenario["fields"][0]["delta"])
    lower = A[:, P + F:P + F + hand.dof]  # u_i >= −η_q (q_i − q_min_i)
    np.testing.assert_array_equal(lower, np.broadcast_to(np.eye(hand.dof), lower.shape))
    # Without fields the same call has no field block.
    A0, _ = hand.cbf_rows(along, obstacles, "euclidean", "both", margins=scenario["margins"]["euclidean"],
                          eta=scenario["eta"], eta_joint=scenario["eta_joint"], threads=1)
    np.testing.assert_array_equal(A0, np.concatenate([A[:, :P], A[:, P + F:]], axis=1))


def test_cell_gradient_is_the_derivative_of_h(hand, barrier, along):
    """evaluate(gradient="cell") is ∇h(x)ᵀ J_x(q) with ∇h the derivative of the interpolated h:
    central differences of h(x(q)) (1e-7 rad or m) within 1e-5 of each row's norm (measured: 3e-9).
    The smoothed ∇h (the rows') is another quantity, O(l_x) from it, which near the handle (l_x =
    2 mm, distances of a few mm) is not small; it points to the same side."""
    eps = 1e-7
    worst, checked = 0.0, 0
    for q in along:
        h, g = barrier.evaluate(q, gradient="cell")
        hs, gs = barrier.evaluate(q)  # smoothed: the same h
        np.testing.assert_array_equal(h, hs)
        assert np.all(np.isfinite(g)) and g.shape == (72, hand.dof)
        fd = np.empty_like(g)
        for j in range(hand.dof):
            e = np.zeros(hand.dof)
            e[j] = eps
            fd[:, j] = (barrier.evaluate(q + e, "cell")[0] - barrier.evaluate(q - e, "cell")[0]) / (2 * eps)
        norm = np.linalg.norm(fd, axis=1)
        assert norm.min() > 1  # h changes with q at every point: the check is not of zeros
        worst = max(worst, float(np.max(np.linalg.norm(g - fd, axis=1) / norm)))
        checked += len(h)
        # The smoothed row is another quantity (measured over the semantic rollout: ‖smoothed −
        # cell‖ / ‖cell‖ median 0.17, up to 2.2 in a few rows beside the handle, where l_x is
        # comparable to the distance); what the controller relies on is that it never pushes the
        # other way.
        ratio = np.linalg.norm(gs - g, axis=1) / np.linalg.norm(g, axis=1)
        assert ratio.max() > 1e-3  # two different gradients
        assert np.all(np.sum(gs * g, axis=1) > 0)  # the smoothed row pushes to the same side
    assert checked == 5 * 72
    assert worst < 1e-5, f"∇h(x)ᵀ J_x(q) against central differences of h(x(q)): {worst:.3g}"


# ---------------------------------------------------------------------------------------------
# bad input


def invalid(fn, *args, **kw):
    with pytest.raises(distlab.InvalidInput) as info:
        fn(*args, **kw)
    return info.value.field, str(info.value)


def test_bad_input_names_the_field(hand, scenario, cache_dir):
    fields, points = scenario["fields"], scenario["control_points"]
    field, message = invalid(hand.field_barrier, fields, [{"link": "panda_thumb", "point": [0, 0, 0]}],
                             cache_dir=cache_dir)
    assert field == "control_points[0].link" and "panda_thumb" in message
    field, _ = invalid(hand.field_barrier, fields, [points[0], {"link": "panda_thumb", "sample": 4}],
                       cache_dir=cache_dir)
    assert field == "control_points[1].link"
    field, _ = invalid(hand.field_barrier, fields, [{"link": "panda_leftfinger", "element": "nail", "sample": 4}],
                       cache_dir=cache_dir)
    assert field == "control_points[0].element"
    no_lx = [{k: v for k, v in fields[0].items() if k != "lx"}]
    assert invalid(hand.field_barrier, no_lx, points, cache_dir=cache_dir)[0] == "fields[0].lx"
    field, message = invalid(hand.field_barrier, [dict(fields[0], mesh={"asset": "spanner"})], points,
                             cache_dir=cache_dir)
    assert field.startswith("fields[0].mesh") and "spanner" in message
    assert invalid(hand.field_barrier, [], points, cache_dir=cache_dir)[0] == "fields"
    assert invalid(hand.field_barrier, fields, [], cache_dir=cache_dir)[0] == "control_points"
    axis = dict(fields[0]["sigma"]["axis"], width=-1)
    assert invalid(hand.field_barrier, [dict(fields[0], sigma={"axis": axis})], points,
                   cache_dir=cache_dir)[0].startswith("fields[0].sigma")
    # A barrier of another robot, and not a barrier at all.
    panda = Robot.load("panda")
    assert invalid(panda.field_barrier, fields, points, cache_dir=cache_dir)[0] == "control_points[0].link"
    assert invalid(hand.cbf_rows, np.zeros(hand.dof), [], fields="wrench")[0] == "fields"


def test_a_point_inside_the_wrench_is_named(hand, scenario, cache_dir, along):
    # The wrench moved so that the left pad's centre point is 20 mm along the handle from the
    # wrench's origin at q = along[2] (inside it: the handle is 5 mm thick); the right pad's
    # centre, 11 mm across, is outside it.
    by_name = {c.get("name"): c for c in scenario["control_points"]}
    left, right = by_name["left_pad_face_11"], by_name["right_pad_face_11"]
    x = world_point(hand, along[2], left["link"], left["point"])
    moved_fields = [dict(scenario["fields"][0], pose={"position": list(x - [0.02, 0, 0])})]
    moved = hand.field_barrier(moved_fields, [right, left], cache_dir=cache_dir)
    assert moved.names == ["right_pad_face_11/wrench", "left_pad_face_11/wrench"]
    with pytest.raises(distlab.FieldUndefined, match="^left_pad_face_11/wrench: h is undefined at configuration 0 "):
        moved.evaluate(along[2])
    with pytest.raises(distlab.FieldUndefined, match="^left_pad_face_11/wrench: h is undefined at configuration 2 "):
        moved.evaluate(along[:3])
    h, _ = moved.evaluate(along[:2])  # elsewhere it is defined
    assert np.all(np.isfinite(h))
    # The rows cannot be formed there either.
    with pytest.raises(distlab.FieldUndefined, match="left_pad_face_11"):
        hand.cbf_rows(along[2], [], "euclidean", fields=moved)
    # A rollout starting there is refused before its first step, naming the point.
    sc = dict(scenario, fields=moved_fields, control_points=[right, left], q0=list(along[2]))
    field, message = invalid(cbf.rollout, sc, "euclidean", {"duration": 0.1})
    assert field == "control_points" and '"left_pad_face_11"' in message and "inside the object" in message


def test_a_start_inside_the_unsafe_set_is_refused(hand, scenario, along):
    # At the handle the pads' h is about 0.47; with δ = 1 they start inside {h < δ}.
    sc = dict(scenario, q0=list(along[3]))
    field, message = invalid(cbf.rollout, sc, "euclidean", {"duration": 0.1, "fields": [{"delta": 1.0}]})
    assert field == "control_points" and "unsafe set" in message and "delta = 1" in message


# ---------------------------------------------------------------------------------------------
# the record


def test_rollout_records_the_fields(hand, barrier, cache_dir, scenario):
    S = 50
    rec = cbf.rollout(SCENARIO, "euclidean", {"duration": S * scenario["dt"]})
    assert rec["steps"] == S and rec["q"].shape == (S, hand.dof)
    kelvin = rec["kelvin"]
    points = kelvin["control_points"]
    assert len(points) == 72 and [p["name"] for p in points] == [p["name"] for p in barrier.points]
    assert all(hand.links[p["link"]] == b["link"] for p, b in zip(points, barrier.points))
    np.testing.assert_array_equal([p["point"] for p in points], [b["point"] for b in barrier.points])
    (f,) = kelvin["fields"]
    assert f["name"] == "wrench" and f["delta"] == 0.2
    assert 0 < f["safety_distance"] < 0.01  # metres: the zero level set a few mm outside the ends
    shapes = {"h": (S, 72), "closest": (S, 3), "closest_sigma": (S,), "distance": (S,), "closest_control_point": (S,),
              "allowed_distance": (S,), "forbidden_distance": (S,)}
    assert {k: np.shape(f[k]) for k in shapes} == shapes
    assert np.issubdtype(np.asarray(f["closest_control_point"]).dtype, np.integer)
    for k in shapes:
        assert np.all(np.isfinite(f[k])), k
    # h is the barrier's at the recorded q (a fresh barrier walks the same cells).
    np.testing.assert_array_equal(f["h"], barrier_of(hand, scenario, cache_dir).evaluate(rec["q"])[0])
    # The closest point is on the wrench (5 mm thick, lying on the table) and its distance is the min.
    assert np.all(np.abs(f["closest"][:, 2]) <= 0.005 + 1e-9)
    assert np.all(f["distance"] <= np.minimum(f["allowed_distance"], f["forbidden_distance"]))
    assert np.all(np.abs(f["closest_sigma"]) <= 0.5 + 1e-12)
    assert "failure" not in kelvin and rec["timing"]["field_us_mean"] > 0

    # σ = 0: no allowed or forbidden faces (NaN) and no safety distance.
    zero = cbf.rollout(SCENARIO, "euclidean", {"duration": 0.1, "fields": [{"sigma": {}}]})["kelvin"]["fields"][0]
    assert zero["safety_distance"] is None and zero["h"].shape == (10, 72)
    assert np.all(np.isnan(zero["allowed_distance"])) and np.all(np.isnan(zero["forbidden_distance"]))
    np.testing.assert_array_equal(zero["closest_sigma"], 0)
    # The hull: no field, the wrench an obstacle of every collision element.
    hull = cbf.rollout(SCENARIO, "euclidean", {"duration": 0.1, "field_mode": "hull"})
    assert "kelvin" not in hull
    wrench = [n for n in hull["pairs"] if n.endswith("/wrench")]
    assert "panda_leftfinger_pad/wrench" in wrench and hull["distance"].shape == (10, len(hull["pairs"]))
