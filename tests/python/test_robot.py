"""distlab.robot: forward kinematics against independent numpy FK (the Panda's DH table, a URDF
with meshes, rotated joint origins and a prismatic joint), every distance Jacobian against
central differences, mesh links against the CLI's convex_hull requests, the pair order, warm
starts, the CBF rows against the built-in controller's, and bad input naming its field."""

import json
import math
import os
import signal
import subprocess
import sys
import time
import warnings

import numpy as np
import pytest

import distlab
from distlab import _core, gap
from distlab.robot import Robot

from conftest import ROOT

PI = math.pi

# ---------------------------------------------------------------------------------------------
# numpy geometry, written here independently of the library


def rot_x(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def rot_y(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]])


def rot_z(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rot_axis(axis, a):
    """Rodrigues: rotation by a about the unit vector axis."""
    k = np.asarray(axis, dtype=float)
    K = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + math.sin(a) * K + (1 - math.cos(a)) * K @ K


def homogeneous(R=np.eye(3), t=(0, 0, 0)):
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = t
    return T


def rpy(r, p, y):
    """URDF's fixed-axis roll, pitch, yaw: Rz(y) Ry(p) Rx(r)."""
    return rot_z(y) @ rot_y(p) @ rot_x(r)


def quat_to_R(q):
    w, x, y, z = q
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                     [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                     [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def R_to_quat(R):
    """[w, x, y, z] of a rotation matrix (Shepperd's method)."""
    t = np.trace(R)
    if t > 0:
        s = 2 * math.sqrt(1 + t)
        return np.array([s / 4, (R[2, 1] - R[1, 2]) / s, (R[0, 2] - R[2, 0]) / s, (R[1, 0] - R[0, 1]) / s])
    i = int(np.argmax(np.diag(R)))
    j, k = (i + 1) % 3, (i + 2) % 3
    s = 2 * math.sqrt(1 + R[i, i] - R[j, j] - R[k, k])
    q = np.empty(4)
    q[0] = (R[k, j] - R[j, k]) / s
    q[1 + i] = s / 4
    q[1 + j] = (R[j, i] + R[i, j]) / s
    q[1 + k] = (R[k, i] + R[i, k]) / s
    return q


def pose_of(T):
    return {"position": T[:3, 3].tolist(), "quaternion": R_to_quat(T[:3, :3]).tolist()}


def assert_poses(fk_row, T, tol=1e-12):
    """A (7,) pose of fk against a 4x4 transform: position, and rotation as a matrix (the
    quaternion's sign is free)."""
    np.testing.assert_allclose(fk_row[:3], T[:3, 3], rtol=0, atol=tol)
    assert abs(np.linalg.norm(fk_row[3:]) - 1) < 1e-12
    np.testing.assert_allclose(quat_to_R(fk_row[3:]), T[:3, :3], rtol=0, atol=tol)


# ---------------------------------------------------------------------------------------------
# The Panda: franka-corridor.md's standard DH table (d, α, a) and joint limits in degrees

PANDA_DH = [(0.333, -PI / 2, 0.0), (0.0, PI / 2, 0.0), (0.316, PI / 2, 0.0825), (0.0, -PI / 2, -0.0825),
            (0.384, PI / 2, 0.0), (0.0, PI / 2, 0.088), (0.177, 0.0, 0.0)]
PANDA_LIMITS_DEG = [(-166, 166), (-101, 101), (-166, 166), (-176, -4), (-166, 166), (-1, 215), (-166, 166)]


def dh_frames(q):
    """Frame i = frame i−1 · Rz(q_i) · Tz(d_i) · Rx(α_i) · Tx(a_i), i = 1..7, and the end effector
    frame 7 · Rz(−π/4)."""
    T = np.eye(4)
    frames = []
    for qi, (d, alpha, a) in zip(q, PANDA_DH):
        T = T @ homogeneous(rot_z(qi)) @ homogeneous(t=(0, 0, d)) @ homogeneous(rot_x(alpha)) @ homogeneous(t=(a, 0, 0))
        frames.append(T)
    return frames, T @ homogeneous(rot_z(-PI / 4))


@pytest.fixture(scope="module")
def panda():
    return Robot.load("panda")


def random_q(robot, rng, n):
    lo, hi = robot.q_min, robot.q_max
    lo = np.where(np.isfinite(lo), lo, -PI)
    hi = np.where(np.isfinite(hi), hi, PI)
    return rng.uniform(lo, hi, size=(n, robot.dof))


# The corridor scene (assets/scenarios/corridor.json) as obstacle dicts, and its GAP params.
def corridor():
    with open(os.path.join(distlab.assets_dir, "scenarios", "corridor.json")) as f:
        s = json.load(f)
    obstacles = [dict(o["shape"], name=o["name"]) for o in s["obstacles"]]
    params = {k: v for k, v in s["gap"].items() if k != "mode"}
    return s, obstacles, params


def test_panda_description_is_the_dh_table(panda):
    assert panda.dof == 7
    assert panda.joint_names == [f"panda_joint{i}" for i in range(1, 8)]
    assert panda.joint_types == ["revolute"] * 7
    np.testing.assert_allclose(panda.q_min, np.radians([lo for lo, _ in PANDA_LIMITS_DEG]), rtol=0, atol=1e-15)
    np.testing.assert_allclose(panda.q_max, np.radians([hi for _, hi in PANDA_LIMITS_DEG]), rtol=0, atol=1e-15)
    assert panda.ee_link == "panda_ee"
    assert [e["link"] for e in panda.collision_elements] == ["panda_link1", "panda_link2", "panda_link3",
                                                              "panda_link4", "panda_link5", "panda_link5",
                                                              "panda_link6", "panda_link7", "panda_link7"]


def test_panda_fk_equals_the_dh_table(panda):
    rng = np.random.default_rng(1)
    Q = random_q(panda, rng, 40)
    poses = panda.fk(Q)
    links = panda.links
    assert poses.shape == (40, len(links), 7)
    for q, P in zip(Q, poses):
        frames, ee = dh_frames(q)
        for i, T in enumerate(frames, start=1):
            assert_poses(P[links.index(f"panda_link{i}")], T)
        assert_poses(P[links.index("panda_ee")], ee)
        assert_poses(P[links.index("panda_link0")], np.eye(4))
    # One configuration: the N axis is dropped, the numbers are the batch's.
    np.testing.assert_array_equal(panda.fk(Q[3]), poses[3])
    np.testing.assert_array_equal(panda.fk(list(Q[3])), poses[3])


def test_jacobian_is_the_derivative_of_fk(panda):
    rng = np.random.default_rng(2)
    h = 1e-6
    point = np.array([0.05, -0.02, 0.1])
    for q in random_q(panda, rng, 5):
        for link in (None, "panda_link4"):
            J = panda.jacobian(q, link, None if link is None else point)
            assert J.shape == (6, 7)
            name = link or panda.ee_link
            li = panda.links.index(name)
            local = np.zeros(3) if link is None else point
            for j in range(7):
                dq = np.zeros(7)
                dq[j] = h
                Pp, Pm = panda.fk(q + dq)[li], panda.fk(q - dq)[li]
                Rp, Rm = quat_to_R(Pp[3:]), quat_to_R(Pm[3:])
                v = ((Pp[:3] + Rp @ local) - (Pm[:3] + Rm @ local)) / (2 * h)
                dR = Rp @ Rm.T  # ≈ exp(2h [ω]×)
                w = np.array([dR[2, 1] - dR[1, 2], dR[0, 2] - dR[2, 0], dR[1, 0] - dR[0, 1]]) / (4 * h)
                np.testing.assert_allclose(J[:3, j], v, rtol=0, atol=1e-8)
                np.testing.assert_allclose(J[3:, j], w, rtol=0, atol=1e-8)
    np.testing.assert_array_equal(panda.jacobian(np.zeros((2, 7)))[1], panda.jacobian(np.zeros(7)))


# ---------------------------------------------------------------------------------------------
# A robot with mesh collision elements: an STL box and an OBJ tetrahedron (relative filenames
# and package://), scaled, on rotated joint origins, with a prismatic and a continuous joint.

BOX_LO, BOX_HI = np.array([-0.03, -0.04, -0.1]), np.array([0.05, 0.02, 0.12])  # off-centre
# a regular tetrahedron of edge 0.1 (needle-like ones break GAP's Property 2 and are refused)
TET = 0.1 * np.array([[0, 0, 0], [1, 0, 0], [0.5, math.sqrt(3) / 2, 0], [0.5, math.sqrt(3) / 6, math.sqrt(2 / 3)]])

MESHBOT_JOINTS = [  # name, type, parent, child, origin xyz, origin rpy, axis, (lower, upper)
    ("j1", "revolute", "base", "l1", (0, 0, 0.12), (0.1, -0.2, 0.3), (0, 0, 1), (-3, 3)),
    ("j2", "prismatic", "l1", "l2", (0.05, 0, 0.35), (0, 0.4, 0), (1, 0, 0), (-0.2, 0.3)),
    ("j3", "continuous", "l2", "l3", (0.3, 0, 0), (0.3, 0, -0.2), (0.6, 0, 0.8), None),
    ("j4", "revolute", "l3", "l4", (0.3, 0, 0), (-0.5, 0.2, 0), (0, 1, 0), (-2, 2)),
]
# link: [(name or None, origin xyz, origin rpy, geometry)]; geometry ("mesh", file in the URDF,
# vertices of the file, scale) or ("box", size) or ("sphere", radius)
MESHBOT_COLLISIONS = {
    "base": [("base_box", (0, 0, 0.04), (0, 0, 0), ("box", (0.3, 0.25, 0.08)))],
    "l1": [("l1_stl", (0, 0, 0.15), (0.2, 0, 0.1), ("mesh", "meshes/box.stl", "box", (1, 1, 1)))],
    "l2": [("l2_tet", (0.1, 0.0, 0.05), (0, 0, 0.5), ("mesh", "package://testpkg/meshes/tet.obj", "tet", (1.3, 0.8, 1.2)))],
    "l3": [("l3_stl", (0.12, 0, 0), (0, 0.3, 0), ("mesh", "meshes/box.stl", "box", (0.5, 1, 0.8))),
           (None, (0.25, 0, 0), (0, 0, 0), ("sphere", 0.04))],
    "l4": [("l4_tet", (0.05, 0, 0), (0.4, 0.1, -0.3), ("mesh", "meshes/tet.obj", "tet", (0.8, 0.8, 0.8)))],
}
MESHBOT_LINKS = ["base", "l1", "l2", "l3", "l4"]


def box_vertices():
    return np.array([[x, y, z] for x in (BOX_LO[0], BOX_HI[0]) for y in (BOX_LO[1], BOX_HI[1])
                     for z in (BOX_LO[2], BOX_HI[2])])


def write_stl_box(path):
    V = box_vertices()
    # 12 triangles over the 6 faces (index = 4 x + 2 y + z of the corner)
    quads = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    lines = ["solid box"]
    for a, b, c, d in quads:
        for tri in ((a, b, c), (a, c, d)):
            lines += ["facet normal 0 0 0", " outer loop"] + [f"  vertex {V[i][0]!r} {V[i][1]!r} {V[i][2]!r}" for i in tri]
            lines += [" endloop", "endfacet"]
    lines.append("endsolid box")
    path.write_text("\n".join(lines) + "\n")


def write_obj_tet(path):
    faces = [(1, 3, 2), (1, 2, 4), (1, 4, 3), (2, 3, 4)]
    path.write_text("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in TET) + "".join(f"f {a} {b} {c}\n" for a, b, c in faces))


def meshbot_urdf():
    out = ['<?xml version="1.0"?>', '<robot name="meshbot">']
    for link in MESHBOT_LINKS:
        out.append(f'  <link name="{link}">')
        for name, xyz, r, geometry in MESHBOT_COLLISIONS[link]:
            out.append(f'    <collision name="{name}">' if name else "    <collision>")
            out.append('      <origin xyz="%r %r %r" rpy="%r %r %r"/>' % (*xyz, *r))
            if geometry[0] == "mesh":
                out.append('      <geometry><mesh filename="%s" scale="%r %r %r"/></geometry>' % (geometry[1], *geometry[3]))
            elif geometry[0] == "box":
                out.append('      <geometry><box size="%r %r %r"/></geometry>' % geometry[1])
            else:
                out.append(f'      <geometry><sphere radius="{geometry[1]!r}"/></geometry>')
            out.append("    </collision>")
        out.append("  </link>")
    for name, kind, parent, child, xyz, r, axis, limits in MESHBOT_JOINTS:
        out += [f'  <joint name="{name}" type="{kind}">', f'    <parent link="{parent}"/>', f'    <child link="{child}"/>',
                '    <origin xyz="%r %r %r" rpy="%r %r %r"/>' % (*xyz, *r), '    <axis xyz="%r %r %r"/>' % axis]
        if limits:
            out.append(f'    <limit lower="{limits[0]}" upper="{limits[1]}" velocity="1" effort="1"/>')
        out.append("  </joint>")
    out.append("</robot>")
    return "\n".join(out) + "\n"


@pytest.fixture(scope="module")
def meshbot_dir(tmp_path_factory):
    root = tmp_path_factory.mktemp("meshbot")
    (root / "robot" / "meshes").mkdir(parents=True)
    (root / "pkg" / "meshes").mkdir(parents=True)
    write_stl_box(root / "robot" / "meshes" / "box.stl")
    write_obj_tet(root / "robot" / "meshes" / "tet.obj")
    write_obj_tet(root / "pkg" / "meshes" / "tet.obj")
    (root / "share" / "testpkg" / "meshes").mkdir(parents=True)  # a package folder: share/testpkg
    write_obj_tet(root / "share" / "testpkg" / "meshes" / "tet.obj")
    (root / "robot" / "meshbot.urdf").write_text(meshbot_urdf())
    return root


@pytest.fixture(scope="module")
def meshbot(meshbot_dir):
    return Robot.from_urdf(meshbot_dir / "robot" / "meshbot.urdf", package_dirs={"testpkg": meshbot_dir / "pkg"})


def meshbot_fk(q):
    """World transform of every link: child = parent · origin · (Rot(axis, q) | Trans(axis q))."""
    T = {"base": np.eye(4)}
    for i, (name, kind, parent, child, xyz, r, axis, _) in enumerate(MESHBOT_JOINTS):
        motion = homogeneous(t=np.asarray(axis) * q[i]) if kind == "prismatic" else homogeneous(rot_axis(axis, q[i]))
        T[child] = T[parent] @ homogeneous(rpy(*r), xyz) @ motion
    return T


def meshbot_elements():
    """(link, origin transform, shape dict without pose) of every collision element, file order."""
    out = []
    for link in MESHBOT_LINKS:
        for name, xyz, r, geometry in MESHBOT_COLLISIONS[link]:
            if geometry[0] == "mesh":
                points = (box_vertices() if geometry[2] == "box" else TET) * np.asarray(geometry[3])
                shape = {"type": "convex_hull", "points": points.tolist()}
            elif geometry[0] == "box":
                # The robot module gives boxes the weight 1/(1 + weight_margin) (distances.hpp).
                shape = {"type": "box", "size": list(geometry[1]), "weights": [1 / 1.01] * 6}
            else:
                shape = {"type": "sphere", "radius": geometry[1]}
            out.append((link, homogeneous(rpy(*r), xyz), shape))
    return out


def test_meshbot_description(meshbot):
    assert meshbot.dof == 4
    assert meshbot.joint_names == ["j1", "j2", "j3", "j4"]
    assert meshbot.joint_types == ["revolute", "prismatic", "revolute", "revolute"]
    assert meshbot.links == MESHBOT_LINKS
    np.testing.assert_array_equal(meshbot.q_min, [-3, -0.2, -np.inf, -2])
    np.testing.assert_array_equal(meshbot.q_max, [3, 0.3, np.inf, 2])
    elements = meshbot.collision_elements
    assert [(e["name"], e["link"], e["element"], e["type"]) for e in elements] == [
        ("base_box", "base", 0, "box"), ("l1_stl", "l1", 0, "convex_hull"), ("l2_tet", "l2", 0, "convex_hull"),
        ("l3_stl", "l3", 0, "convex_hull"), ("l3/collision[1]", "l3", 1, "sphere"), ("l4_tet", "l4", 0, "convex_hull")]
    assert elements[2]["mesh"] == "package://testpkg/meshes/tet.obj" and elements[0]["mesh"] is None
    for e, (link, origin, _) in zip(elements, meshbot_elements()):
        assert_poses(e["pose"], origin)


def test_package_search_dirs_find_the_package(meshbot, meshbot_dir):
    found = Robot.from_urdf(meshbot_dir / "robot" / "meshbot.urdf", package_search_dirs=[meshbot_dir / "nothing",
                                                                                        meshbot_dir / "share"])
    Q = random_q(meshbot, np.random.default_rng(9), 4)
    np.testing.assert_array_equal(found.distances(Q, OBSTACLES, pairs="both").distance,
                                  meshbot.distances(Q, OBSTACLES, pairs="both").distance)
    with pytest.raises(distlab.InvalidInput, match="testpkg"):
        Robot.from_urdf(meshbot_dir / "robot" / "meshbot.urdf", package_search_dirs=[meshbot_dir / "robot"])


def test_meshbot_fk_equals_numpy(meshbot):
    rng = np.random.default_rng(3)
    Q = random_q(meshbot, rng, 30)
    poses = meshbot.fk(Q)
    for q, P in zip(Q, poses):
        T = meshbot_fk(q)
        for i, link in enumerate(MESHBOT_LINKS):
            assert_poses(P[i], T[link])


OBSTACLES = [  # three distinct shapes at distinct places: a wrong pair order gives other numbers
    {"type": "box", "size": [0.2, 0.3, 0.25], "pose": {"position": [0.45, 0.1, 0.5], "quaternion": [0.9, 0.1, 0.3, 0.2]},
     "weights": [0.99009900990099] * 6, "name": "crate"},
    {"type": "sphere", "radius": 0.08, "pose": {"position": [-0.2, 0.35, 0.4]}},
    {"type": "cylinder", "radius": 0.05, "height": 0.4, "pose": {"position": [0.1, -0.4, 0.6],
                                                                   "quaternion": [0.8, 0.6, 0, 0]}, "name": "pole"},
]


def cli_pair(a, pose_a, b, pose_b):
    """The CLI's answer (distlab.gap.solve: `distlab gap` bit for bit) for one pair."""
    return gap.solve({"a": dict(a, pose=pose_a), "b": dict(b, pose=pose_b)})


@pytest.mark.parametrize("metric", ["gap", "euclidean"])
def test_meshbot_distances_are_the_cli_convex_hull_requests_in_the_documented_order(meshbot, metric):
    """Pair p: obstacle pairs element-major (element e, obstacle o at p = e * 3 + o), then the self
    pairs (i, j), i < j, of links two or more joints apart: each distance and witness is the CLI's
    for the element's convex_hull (the scaled mesh vertices) at its FK pose."""
    rng = np.random.default_rng(4)
    elements = meshbot_elements()
    ne, no = len(elements), len(OBSTACLES)
    # links two or more moving joints apart (a chain: index difference >= 2)
    self_pairs = [(i, j) for i in range(ne) for j in range(i + 1, ne)
                  if MESHBOT_LINKS.index(elements[j][0]) - MESHBOT_LINKS.index(elements[i][0]) >= 2]
    Q = random_q(meshbot, rng, 6)
    d = meshbot.distances(Q, OBSTACLES, metric, "both", threads=1, tracking=False)
    P = ne * no + len(self_pairs)
    assert d.distance.shape == (6, P) and d.jacobian.shape == (6, P, 4) and d.witness_robot.shape == (6, P, 3)
    names = [e["name"] for e in meshbot.collision_elements]
    obstacle_names = ["crate", "obstacle1", "pole"]  # the sphere has no name: "obstacle<i>"
    expected = [dict(name=f"{names[e]}/{obstacle_names[o]}", self=False, link=elements[e][0],
                     element=meshbot.collision_elements[e]["element"], element_name=names[e], obstacle=o,
                     obstacle_name=obstacle_names[o], other_link=None, other_element=None, other_element_name=None)
                for e in range(ne) for o in range(no)]
    expected += [dict(name=f"{names[i]}/{names[j]}", self=True, link=elements[i][0],
                      element=meshbot.collision_elements[i]["element"], element_name=names[i], obstacle=None,
                      obstacle_name=None, other_link=elements[j][0],
                      other_element=meshbot.collision_elements[j]["element"], other_element_name=names[j])
                 for i, j in self_pairs]
    assert d.pairs == expected
    obstacle_shapes = [{k: v for k, v in o.items() if k not in ("pose", "name")} for o in OBSTACLES]
    checked = 0
    for n, q in enumerate(Q):
        T = meshbot_fk(q)
        pose = [pose_of(T[link] @ origin) for link, origin, _ in elements]
        pairs = [(e, elements[e][2], obstacle_shapes[o], OBSTACLES[o]["pose"]) for e in range(ne) for o in range(no)]
        pairs += [(i, elements[i][2], elements[j][2], pose[j]) for i, j in self_pairs]
        for p, (e, a, b, pose_b) in enumerate(pairs):
            cli = cli_pair(a, pose[e], b, pose_b)
            if metric == "gap":
                want, wa, wb, overlap = cli["distance"], cli["witness_a"], cli["witness_b"], cli["overlap"]
            else:
                eu = cli["euclidean"]
                want, wa, wb, overlap = eu["distance"], eu["witness_a"], eu["witness_b"], eu["distance"] <= 0
            assert d.overlap[n, p] == overlap, d.pairs[p]["name"]
            if overlap:
                assert d.distance[n, p] == 0
                continue
            checked += 1
            assert d.distance[n, p] == pytest.approx(want, rel=1e-9, abs=1e-12), d.pairs[p]["name"]
            # GAP's witnesses are unique (strictly convex sets); FCL's are GJK's, to ~1e-8
            tol = 1e-8 if metric == "gap" else EUCLIDEAN_WITNESS_ERROR
            np.testing.assert_allclose(d.witness_robot[n, p], wa, rtol=0, atol=tol)
            np.testing.assert_allclose(d.witness_obstacle[n, p], wb, rtol=0, atol=tol)
    assert checked >= 0.8 * 6 * P


def write_obj_prism(path, sides, radius, length):
    """A cylinder as a robot maker meshes it: `sides` quads around, flat fan-triangulated caps."""
    t = 2 * np.pi * np.arange(sides) / sides
    ring = np.column_stack([radius * np.cos(t), radius * np.sin(t)])
    V = [(x, y, 0.0) for x, y in ring] + [(x, y, length) for x, y in ring] + [(0.0, 0.0, 0.0), (0.0, 0.0, length)]
    F = []
    for k in range(sides):
        a, b = k, (k + 1) % sides
        F += [(a, b, b + sides), (a, b + sides, a + sides), (2 * sides, b, a), (2 * sides + 1, a + sides, b + sides)]
    path.write_text("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in V) + "".join(f"f {a + 1} {b + 1} {c + 1}\n" for a, b, c in F))
    return np.array(V)


def test_a_finely_meshed_link_is_accepted_with_the_defaults(tmp_path):
    """A link meshed like a real robot's base (300 sides, flat caps: a hull of 302 facets) passes
    the Property 2 check with the default params (with W = 1/m its caps weighed 1/150 each and it
    was refused); its distances are the CLI's convex_hull answers and dD/dq its derivative."""
    points = write_obj_prism(tmp_path / "base.obj", 300, 0.04, 0.16)
    (tmp_path / "bot.urdf").write_text(
        '<robot name="bot"><link name="world"/><link name="l1"><collision><geometry>'
        '<mesh filename="base.obj"/></geometry></collision></link>'
        '<joint name="j" type="revolute"><parent link="world"/><child link="l1"/><origin xyz="0 0 0.1" rpy="0.3 0 0"/>'
        '<axis xyz="1 0 0"/><limit lower="-2" upper="2" effort="1" velocity="1"/></joint></robot>')
    robot = Robot.from_urdf(tmp_path / "bot.urdf")
    obstacles = [{"type": "cylinder", "radius": 0.05, "height": 0.2, "pose": {"position": [0.0, 0.25, 0.2]}},
                 {"type": "sphere", "radius": 0.05, "pose": {"position": [0.2, 0.0, 0.3]}}]
    q = np.array([0.4])
    J, fd, d = central_differences(robot, q, obstacles, "gap", "obstacles", 1e-4)
    assert np.isfinite(d.distance).all() and not d.overlap.any() and d.converged.all()
    assert_jacobians(J, fd, d.distance, 1e-4, np.ones(len(d.pairs), bool), "prism link")
    T = homogeneous(rot_x(0.3), (0, 0, 0.1)) @ homogeneous(rot_x(q[0]))
    hull = {"type": "convex_hull", "points": points.tolist()}
    for p, o in enumerate(obstacles):
        cli = cli_pair(hull, pose_of(T), {k: v for k, v in o.items() if k != "pose"}, o["pose"])
        assert d.distance[0, p] == pytest.approx(cli["distance"], rel=1e-9, abs=1e-12)


def test_a_millimetre_element_takes_its_own_h_with_a_warning(tmp_path):
    """An IMU's 2 mm box on a link (as in quadrupeds' descriptions) breaks Property 2 at h = 0.1:
    it takes its own h, which a UserWarning names exactly, once per model. With that h alone the
    element passes the check the model itself refuses at h = 0.1; distances are finite, converged,
    and dD/dq is their derivative. An obstacle of that size is still refused, naming it."""
    (tmp_path / "imu.urdf").write_text(
        '<robot name="imu"><link name="world"/><link name="l1">'
        '<collision><origin xyz="0.15 0 0"/><geometry><cylinder radius="0.04" length="0.3"/></geometry></collision>'
        '<collision><origin xyz="0.05 0 0.045"/><geometry><box size="0.002 0.002 0.002"/></geometry></collision></link>'
        '<joint name="j" type="revolute"><parent link="world"/><child link="l1"/><origin xyz="0 0 0.1"/>'
        '<axis xyz="0 1 0"/><limit lower="-1.5" upper="1.5" effort="1" velocity="1"/></joint></robot>')
    robot = Robot.from_urdf(tmp_path / "imu.urdf")
    assert robot.warnings == []
    obstacles = [{"type": "sphere", "radius": 0.05, "pose": {"position": [0.3, 0.2, 0.3]}}]
    q = np.array([0.3])
    with pytest.warns(UserWarning, match=r'collision element "l1/collision\[1\]": bounding radius .* small against '
                                         r'h = 0.1: its GAP function takes h = ') as caught:
        J, fd, d = central_differences(robot, q, obstacles, "gap", "obstacles", 1e-4)
    own = float(str(caught[0].message).split("takes h = ")[1].split(",")[0])
    assert 0 < own < 0.1
    assert np.isfinite(d.distance).all() and not d.overlap.any() and d.converged.all()
    assert_jacobians(J, fd, d.distance, 1e-4, np.ones(len(d.pairs), bool), "imu link")
    # The warning's h is the element's: the CLI's Property 2 check passes the box there, not at 0.1.
    box = {"type": "box", "size": [0.002, 0.002, 0.002]}
    ball = {"type": "sphere", "radius": 0.05, "pose": {"position": [0.3, 0, 0]}}
    assert gap.solve({"a": box, "b": ball, "params": {"h": own, "validate": True}})["distance"] > 0
    with pytest.raises(distlab.InvalidInput):
        gap.solve({"a": box, "b": ball, "params": {"h": 0.1, "validate": True}})
    # The same box as an obstacle is the caller's own: refused at h = 0.1, naming it.
    with pytest.raises(distlab.InvalidInput) as e:
        robot.distances(q, [dict(box, pose={"position": [0.5, 0, 0.5]})])
    assert e.value.field == "obstacles[0]"


def test_box_obstacles_take_the_weight_of_the_scenarios(meshbot):
    """A box without weights is weighted 1/(1 + weight_margin) (robot/distances.hpp), as documented:
    the CLI's answer with those weights given, not with the gap library's default."""
    q = np.array([0.3, 0.1, 0.5, -0.4])
    box = {"type": "box", "size": [0.2, 0.1, 0.3], "pose": {"position": [0.4, 0.3, 0.5]}}
    for wm in (0.01, 0.2):
        d = meshbot.distances(q, [box], params={"weight_margin": wm}, tracking=False)
        link, origin, hull = meshbot_elements()[1]
        pose = pose_of(meshbot_fk(q)[link] @ origin)
        weighted = dict(box, weights=[1 / (1 + wm)] * 6)
        cli = gap.solve({"a": dict(hull, pose=pose), "b": weighted, "params": {"weight_margin": wm}})
        default = gap.solve({"a": dict(hull, pose=pose), "b": box, "params": {"weight_margin": wm}})
        assert d.distance[1] == pytest.approx(cli["distance"], rel=1e-9)
        assert abs(default["distance"] - cli["distance"]) > 1e-4 * cli["distance"]


def test_calls_from_python_threads_run_in_parallel_and_agree(panda):
    """The GIL is released during the work: two Python threads with their own batches give what
    each gives alone (one model, shared read-only)."""
    import threading

    _, obstacles, params = corridor()
    Qs = [trajectory(panda, 150, seed) for seed in (11, 12)]
    alone = [panda.distances(Q, obstacles, "gap", "both", params, threads=1).distance for Q in Qs]
    out = [None, None]

    def run(i):
        out[i] = panda.distances(Qs[i], obstacles, "gap", "both", params, threads=1).distance

    threads = [threading.Thread(target=run, args=(i,)) for i in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    for a, b in zip(alone, out):
        np.testing.assert_array_equal(a, b)
    # distlab.gap.Params is taken too: its defaults are the defaults
    q = Qs[0][0]
    np.testing.assert_array_equal(panda.distances(q, obstacles, params=gap.Params()).distance,
                                  panda.distances(q, obstacles).distance)


# ---------------------------------------------------------------------------------------------
# Jacobians against central differences


def central_differences(robot, q, obstacles, metric, pairs, h, params=None):
    """dD/dq of every pair at q by fourth-order central differences (cold solves),
    (8 (D(q + h) − D(q − h)) − (D(q + 2h) − D(q − 2h))) / 12h: truncation O(h⁴), so a step large
    enough to keep D's rounding out of the quotient. Also the analytic Jacobian and the distances."""
    n = robot.dof
    E = np.eye(n) * h
    Q = np.vstack([q[None], q + E, q - E, q + 2 * E, q - 2 * E])
    d = robot.distances(Q, obstacles, metric, pairs, params=params, threads=1, tracking=False)
    D = d.distance
    fd = ((8 * (D[1:n + 1] - D[n + 1:2 * n + 1]) - (D[2 * n + 1:3 * n + 1] - D[3 * n + 1:])) / (12 * h)).T
    return d.jacobian[0], fd, d


def assert_jacobians(J, fd, D, h, ok, what, absolute=0.0):
    """|J − fd| <= 1e-6 |J| per pair (max over joints), or below the quotient's rounding noise
    (64 ulp of D over h: pairs whose gradient is ~0), plus `absolute`."""
    err = np.abs(J - fd).max(axis=1)
    scale = np.abs(J).max(axis=1)
    noise = 64 * np.spacing(np.abs(D).max(axis=0)) / h
    bad = ok & ~(err <= np.maximum(1e-6 * scale, noise) + absolute)
    assert not bad.any(), f"{what}: pairs {np.flatnonzero(bad)}: error {err[bad]} against |J| {scale[bad]}"


# FCL's GJK (cylinders, meshes) gives witness points to about 1e-8 m, while its distances are
# accurate to rounding: the Euclidean Jacobian, the normal through the witness points times their
# velocities, inherits that error (box–box pairs, solved exactly, have none).
EUCLIDEAN_WITNESS_ERROR = 1e-7


@pytest.mark.parametrize("metric", ["gap", "euclidean"])
@pytest.mark.parametrize("which", ["panda", "meshbot"])
def test_jacobians_match_central_differences(request, which, metric):
    robot = request.getfixturevalue(which)
    _, obstacles, _ = corridor()
    if which == "meshbot":
        obstacles = OBSTACLES
    rng = np.random.default_rng(5)
    checked = 0
    # GAP's D is smooth wherever the pair is apart; the Euclidean distance has kinks where the
    # closest features change (a box's face to its edge), met within 1e-4 rad now and then: a
    # smaller step keeps the quotient on one side.
    h = 1e-4 if metric == "gap" else 1e-6
    for q in random_q(robot, rng, 8):
        J, fd, d = central_differences(robot, q, obstacles, metric, "both", h)
        ok = ~d.overlap.any(axis=0) & (d.distance.min(axis=0) > 1e-3)
        assert_jacobians(J, fd, d.distance, h, ok, f"{which} {metric} q={q.tolist()}",
                         EUCLIDEAN_WITNESS_ERROR if metric == "euclidean" else 0.0)
        checked += ok.sum()
    pairs = len(d.pairs)
    assert checked >= 0.7 * 8 * pairs and any(p["self"] for p in d.pairs)


def test_gap_jacobian_near_contact(panda):
    """A sphere moved to 1e-4 m (Euclidean) from one collision element (a different one each
    time): D is ~3e-11 there, and the GAP Jacobian of that pair still matches central
    differences to 1e-6 relative."""
    rng = np.random.default_rng(6)
    checked = []
    for trial, q in enumerate(random_q(panda, rng, 9)):
        sphere = {"type": "sphere", "radius": 0.05, "pose": {"position": [0.5, 0.3, 0.6]}}
        e = panda.distances(q, [sphere], "euclidean")
        for k in [(trial + i) % 9 for i in range(9)]:
            if e.overlap[k]:
                continue
            # Towards the element along the witnesses' segment: the element's witness stays the
            # closest point of the sphere's centre, the gap shrinks to 1e-4.
            n = e.witness_obstacle[k] - e.witness_robot[k]
            n /= np.linalg.norm(n)
            centre = np.array(sphere["pose"]["position"]) - (e.distance[k] - 1e-4) * n
            near = dict(sphere, pose={"position": centre.tolist()})
            assert panda.distances(q, [near], "euclidean").distance[k] == pytest.approx(1e-4, rel=1e-9)
            J, fd, d = central_differences(panda, q, [near], "gap", "obstacles", 1e-5)
            assert not d.overlap[:, k].any() and 0 < d.distance[0, k] < 1e-9
            assert_jacobians(J[k:k + 1], fd[k:k + 1], d.distance[:, k:k + 1], 1e-5, np.array([True]),
                             f"near contact, element {k}")
            checked.append(k)
            break
    assert len(set(checked)) >= 6


# ---------------------------------------------------------------------------------------------
# Warm starts


def trajectory(robot, n, seed=7):
    rng = np.random.default_rng(seed)
    q0 = random_q(robot, rng, 1)[0] * 0.5
    t = np.linspace(0, 2, n)[:, None]
    return q0 + 0.3 * np.sin(2 * t * rng.uniform(0.5, 1.5, robot.dof) + rng.uniform(0, 2 * PI, robot.dof))


def test_tracked_equals_cold_and_warm_start_continues_the_batch(panda):
    _, obstacles, params = corridor()
    Q = trajectory(panda, 240)
    tracked = panda.distances(Q, obstacles, "gap", "both", params, threads=1)
    cold = panda.distances(Q, obstacles, "gap", "both", params, threads=1, tracking=False)
    np.testing.assert_allclose(tracked.distance, cold.distance, rtol=0, atol=1e-9)
    np.testing.assert_allclose(tracked.jacobian, cold.jacobian, rtol=0, atol=1e-9)
    np.testing.assert_allclose(tracked.witness_robot, cold.witness_robot, rtol=0, atol=1e-9)
    assert tracked.converged.all() and cold.converged.all()
    assert tracked.iterations.mean() < cold.iterations.mean()  # what tracking is for
    # The same trajectory in calls of 1, 7, 32, ... configurations, each continuing the last
    # call's state: bit for bit the one batch (a cold restart would differ in the last bits).
    state, parts, i = None, [], 0
    for size in [1, 7, 32, 1, 100, 99]:
        part = panda.distances(Q[i:i + size] if size > 1 else Q[i], obstacles, "gap", "both", params, threads=1,
                               warm_start=state)
        parts.append(part.distance.reshape(-1, tracked.distance.shape[1]))
        state, i = part, i + size
    np.testing.assert_array_equal(np.vstack(parts), tracked.distance)
    restarted = panda.distances(Q[8:40], obstacles, "gap", "both", params, threads=1)
    assert not np.array_equal(restarted.distance, tracked.distance[8:40])
    # Two threads: the second half starts cold, the same answers within the tolerance.
    two = panda.distances(Q, obstacles, "gap", "both", params, threads=2)
    np.testing.assert_allclose(two.distance, tracked.distance, rtol=0, atol=1e-9)


def test_warm_start_is_refused_from_another_model(panda):
    _, obstacles, params = corridor()
    q = trajectory(panda, 3)
    base = panda.distances(q, obstacles, "gap", "both", params)

    def field_of(**kw):
        args = dict(obstacles=obstacles, metric="gap", pairs="both", params=params, warm_start=base)
        args.update(kw)
        with pytest.raises(distlab.InvalidInput) as info:
            panda.distances(q, **args)
        return info.value.field, str(info.value)

    resized = [dict(o) for o in obstacles]
    resized[0] = dict(resized[0], size=[0.3, 0.05, 0.9])
    assert field_of(obstacles=resized)[0] == "warm_start"
    # The message names its field itself, so the text does not repeat it (InvalidInput).
    assert field_of(metric="euclidean") == ("warm_start", 'warm_start comes from the metric "gap", not "euclidean"')
    assert field_of(pairs="obstacles")[0] == "warm_start"
    assert field_of(params=dict(params, h=0.2))[0] == "warm_start"
    assert field_of(warm_start="state")[0] == "warm_start"
    assert field_of(tracking=False)[0] == "warm_start"
    ur5e = Robot.load("ur5e")
    other = ur5e.distances(np.zeros(ur5e.dof), obstacles, "gap", "both", params)
    assert "another robot" in field_of(warm_start=other)[1]
    # The same combination after its model left the cache (8 others since) is accepted, and
    # continues the state bit for bit.
    for k in range(9):
        panda.distances(q[0], [dict(obstacles[0], name=f"other{k}")], "gap")
    after = panda.distances(q, obstacles, "gap", "both", params, warm_start=base)
    again = panda.distances(q, obstacles, "gap", "both", params, warm_start=base)
    np.testing.assert_array_equal(after.distance, again.distance)


# ---------------------------------------------------------------------------------------------
# CBF rows


@pytest.mark.parametrize("metric", ["gap", "euclidean"])
def test_cbf_rows_equal_the_built_in_controllers(panda, metric):
    scenario, obstacles, params = corridor()
    rec = distlab.cbf.rollout("corridor", metric, {"duration": 0.6, "record_pairs": True})
    Q = rec["q"]
    C, dvec, names = _core.cbf_controller_rows({"scenario": "corridor", "metric": metric}, Q)
    rows = panda.cbf_rows(Q, obstacles, metric, "both", params=params, threads=1)
    A, b = rows
    assert rows.distances.names == names == list(rec["pairs"])
    assert A.shape == C.shape == (len(Q), len(names) + 14, 7)
    # One thread tracks along the trajectory as the controller does: the same rows, bit for bit.
    np.testing.assert_array_equal(A, C)
    np.testing.assert_array_equal(b, dvec)
    # The rollout's recorded distances are the rows' distances (record q_t is where step t ran).
    np.testing.assert_array_equal(rows.distances.distance, rec["distance"])
    # Two threads: the second half starts cold; the same rows within the solver's tolerance.
    A2, b2 = panda.cbf_rows(Q, obstacles, metric, "both", params=params, threads=2)
    np.testing.assert_allclose(A2, C, rtol=0, atol=1e-9)
    np.testing.assert_allclose(b2, dvec, rtol=0, atol=1e-9)
    # Row p against the pair's margin: the self pairs take the self margin.
    margins = scenario["margins"][metric]
    P = len(names)
    delta = np.array([margins["self"] if p["self"] else margins["obstacle"] for p in rows.distances.pairs])
    assert len(set(delta)) == 2
    np.testing.assert_allclose(b[:, :P], -scenario["eta"] * (rows.distances.distance - delta), rtol=0, atol=1e-15)


def test_cbf_rows_layout_margins_and_continuous_joints(meshbot):
    rng = np.random.default_rng(8)
    q = random_q(meshbot, rng, 1)[0]
    margins = {"obstacle": 0.05, "self": 0.02}
    A, b = rows = meshbot.cbf_rows(q, OBSTACLES, "euclidean", margins=margins, eta=0.7, eta_joint=0.3)
    d = rows.distances
    P = len(d.pairs)
    # the continuous joint j3 has no limit rows: 3 lower, then 3 upper
    assert A.shape == (P + 6, 4) and b.shape == (P + 6,)
    np.testing.assert_array_equal(A[:P], d.jacobian)
    delta = np.where([p["self"] for p in d.pairs], 0.02, 0.05)
    np.testing.assert_allclose(b[:P], -0.7 * (d.distance - delta), rtol=0, atol=1e-15)
    bounded = [0, 1, 3]
    np.testing.assert_array_equal(A[P:P + 3], np.eye(4)[bounded])
    np.testing.assert_array_equal(A[P + 3:], -np.eye(4)[bounded])
    np.testing.assert_allclose(b[P:P + 3], -0.3 * (q[bounded] - meshbot.q_min[bounded]), rtol=0, atol=1e-15)
    np.testing.assert_allclose(b[P + 3:], -0.3 * (meshbot.q_max[bounded] - q[bounded]), rtol=0, atol=1e-15)
    # Beyond a limit: accepted, and that limit's row asks the joint back (b > 0).
    beyond = q.copy()
    beyond[bounded[0]] = meshbot.q_max[bounded[0]] + 0.3
    _, b_beyond = meshbot.cbf_rows(beyond, OBSTACLES, "euclidean", margins=margins, eta=0.7, eta_joint=0.3)
    assert b_beyond[P + 3] == pytest.approx(0.09, abs=1e-15) and (b_beyond[P:P + 3] < 0).all()
    # Default margins: the scenario's per metric.
    default = meshbot.cbf_rows(q, OBSTACLES, "gap", pairs="obstacles")
    np.testing.assert_allclose(default.b[:len(default.distances.pairs)],
                               -0.5 * (default.distances.distance - 0.002), rtol=0, atol=1e-15)


def test_cbf_rows_name_the_overlapping_pairs(meshbot):
    """An overlapping pair's row holds for no u: a UserWarning names it (and only then)."""
    q = random_q(meshbot, np.random.default_rng(8), 1)[0]
    apart = [{"type": "sphere", "radius": 0.05, "pose": {"position": [3.0, 0, 0]}, "name": "far"}]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        rows = meshbot.cbf_rows(q, apart, "euclidean", pairs="obstacles")
    assert not rows.distances.overlap.any()
    engulfing = [{"type": "sphere", "radius": 5.0, "pose": {"position": [0, 0, 0]}, "name": "engulfing"}]
    with pytest.warns(UserWarning, match="overlap") as caught:
        rows = meshbot.cbf_rows(np.stack([q, q]), engulfing, "euclidean", pairs="obstacles")
    assert rows.distances.overlap.all()
    message = str(caught[0].message)
    names = rows.distances.names
    assert all(name in message for name in names[:4]) and (len(names) <= 4 or f"{len(names) - 4} more" in message)
    assert (rows.b[:, :len(names)] > 0).all() and not rows.A[:, :len(names)].any()  # 0 · u >= b > 0


# ---------------------------------------------------------------------------------------------
# Shapes and bad input


def test_single_configuration_drops_the_n_axis(panda):
    _, obstacles, _ = corridor()
    q = trajectory(panda, 2)
    one = panda.distances(q[1], obstacles, tracking=False)
    two = panda.distances(q, obstacles, tracking=False)
    P = len(one.pairs)
    assert one.distance.shape == (P,) and one.jacobian.shape == (P, 7) and one.witness_obstacle.shape == (P, 3)
    assert one.overlap.dtype == bool and one.converged.shape == (P,)
    np.testing.assert_array_equal(one.distance, two.distance[1])
    np.testing.assert_array_equal(one.jacobian, two.jacobian[1])
    empty = panda.distances(np.zeros((0, 7)), obstacles)
    assert empty.distance.shape == (0, P) and empty.jacobian.shape == (0, P, 7)
    none = panda.distances(q, [])
    assert none.distance.shape == (2, 0) and none.pairs == []


def test_moved_obstacles_continue_the_state(panda):
    """Obstacles moved between calls keep their model (its key leaves the poses out), and the
    previous call's state continues: each call equals a cold solve of the moved scene within the
    solver's tolerance, and the moves do change the distances."""
    _, obstacles, params = corridor()
    q = trajectory(panda, 12)
    state = None
    for k in range(4):
        moved = []
        for j, o in enumerate(obstacles):
            pose = o.get("pose", {})
            position = np.asarray(pose.get("position", [0, 0, 0]), float) + (k + 1) * 1e-3 * np.array([1, -j, 0.5])
            moved.append(dict(o, pose=dict(pose, position=position.tolist())))
        part = q[3 * k:3 * k + 3]
        got = panda.distances(part, moved, "gap", "both", params, warm_start=state)
        state = got.state
        cold = panda.distances(part, moved, "gap", "both", params, tracking=False)
        unmoved = panda.distances(part, obstacles, "gap", "both", params, tracking=False)
        apart = ~cold.overlap
        np.testing.assert_allclose(got.distance[apart], cold.distance[apart], rtol=1e-12)
        np.testing.assert_allclose(got.witness_robot, cold.witness_robot, rtol=0, atol=2e-10)
        moving = apart & np.array([not p["self"] for p in got.pairs])[None, :]
        assert moving.sum() > 0
        assert np.all(got.distance[moving] != unmoved.distance[moving])


def test_obstacle_gradient_is_the_pose_derivative(panda):
    """obstacle_gradient (N, P, 6) is dD/d(v, ω) of each obstacle: central differences of the
    distances with the obstacle moved along and turned about each world axis (about its origin);
    zeros for self pairs. The Euclidean distance is not differentiable in a turn where nearest
    features are parallel (a link's cylinder beside a wall): there its gradient lies between the
    one-sided quotients (D = min over the witness pairs)."""
    _, obstacles, params = corridor()
    q = trajectory(panda, 3)
    step = 1e-6

    def turned(quaternion, axis, angle):
        w, x, y, z = quaternion
        c, s = np.cos(angle / 2), np.sin(angle / 2)
        a = np.eye(3)[axis] * s  # (c, a) * (w, x, y, z)
        v = np.array([x, y, z])
        return [c * w - a @ v, *(c * v + w * a + np.cross(a, v))]

    for metric in ("gap", "euclidean"):
        base = panda.distances(q, obstacles, metric, "both", params, tracking=False)
        assert base.obstacle_gradient.shape == base.distance.shape + (6,)
        self_pairs = np.array([p["self"] for p in base.pairs])
        assert np.all(base.obstacle_gradient[:, self_pairs] == 0)
        worst, checked = 0.0, 0
        for j, o in enumerate(obstacles):
            pose = o.get("pose", {})
            position = np.asarray(pose.get("position", [0, 0, 0]), float)
            quaternion = pose.get("quaternion", [1, 0, 0, 0])
            mine = np.array([p["obstacle"] == j for p in base.pairs])
            for k in range(6):
                moved = []
                for sign in (1, -1):
                    if k < 3:
                        new = dict(pose, position=(position + sign * step * np.eye(3)[k]).tolist())
                    else:
                        new = dict(pose, position=position.tolist(), quaternion=turned(quaternion, k - 3, sign * step))
                    scene = [dict(other, pose=new) if i == j else other for i, other in enumerate(obstacles)]
                    moved.append(panda.distances(q, scene, metric, "both", params, tracking=False).distance)
                use = mine[None, :] & (base.distance > 5e-3)
                scale = np.maximum(np.abs(base.obstacle_gradient).max(axis=2), 1e-3)[use]
                g = base.obstacle_gradient[..., k][use]
                if metric == "euclidean" and k >= 3:
                    right = (moved[0] - base.distance)[use] / step
                    left = (base.distance - moved[1])[use] / step
                    assert np.all(right - g <= 1e-5 * scale) and np.all(g - left <= 1e-5 * scale)
                    continue
                fd = ((moved[0] - moved[1]) / (2 * step))[use]
                worst = max(worst, float(np.max(np.abs(fd - g) / scale)))
                checked += int(use.sum())
        assert checked > 3 * (6 if metric == "gap" else 3) * 9
        assert worst < 1e-6, (metric, worst)


def test_moved_obstacle_gives_its_new_distances(panda):
    """The model cache is keyed by the obstacles' values, not the list object: editing a pose in
    place between calls gives the new distances."""
    q = trajectory(panda, 1)[0]
    sphere = {"type": "sphere", "radius": 0.05, "pose": {"position": [0.5, 0.0, 0.5]}}
    obstacles = [sphere]
    first = panda.distances(q, obstacles, "euclidean").distance.copy()
    sphere["pose"]["position"][2] = 0.9
    second = panda.distances(q, obstacles, "euclidean").distance
    fresh = panda.distances(q, [{"type": "sphere", "radius": 0.05, "pose": {"position": [0.5, 0.0, 0.9]}}], "euclidean")
    np.testing.assert_array_equal(second, fresh.distance)
    assert not np.array_equal(first, second)


def invalid(fn, *args, **kw):
    with pytest.raises(distlab.InvalidInput) as info:
        fn(*args, **kw)
    return info.value.field


def test_bad_input_names_the_field(panda):
    _, obstacles, _ = corridor()
    q = np.zeros(7)
    assert invalid(panda.distances, np.zeros(6), obstacles) == "q"
    assert invalid(panda.distances, np.zeros((3, 6)), obstacles) == "q"
    assert invalid(panda.fk, np.zeros((2, 3, 7))) == "q"
    assert invalid(panda.distances, [0, 0, 0, np.nan, 0, 0, 0], obstacles) == "q[3]"
    Q = np.zeros((4, 7))
    Q[2, 5] = np.inf
    assert invalid(panda.distances, Q, obstacles) == "q[2][5]"
    assert invalid(panda.cbf_rows, Q, obstacles) == "q[2][5]"
    assert invalid(panda.fk, Q) == "q[2][5]"
    assert invalid(panda.distances, ["a"] * 7, obstacles) == "q"
    bad = [obstacles[0], {"type": "box", "size": [0.1, -1, 0.1]}]
    assert invalid(panda.distances, q, bad) == "obstacles[1].size[1]"
    assert invalid(panda.distances, q, [{"size": [1, 1, 1]}]) == "obstacles[0].type"
    assert invalid(panda.distances, q, [{"type": "sphere", "radius": 0.1, "colour": "red"}]) == "obstacles[0].colour"
    assert invalid(panda.distances, q, [{"type": "sphere", "radius": 0.1, "name": 3}]) == "obstacles[0].name"
    assert invalid(panda.distances, q, {"type": "sphere", "radius": 0.1}) == "obstacles"
    twice = [dict(obstacles[0], name="wall"), dict(obstacles[1], name="wall")]
    assert invalid(panda.distances, q, twice) == "obstacles[1].name"
    # An obstacle without a name is "obstacle<i>" (as over HTTP); a default another one took is
    # refused as a repeated name is.
    unnamed = {k: v for k, v in obstacles[1].items() if k != "name"}
    assert panda.distances(q, [obstacles[0], unnamed]).pairs[1]["obstacle_name"] == "obstacle1"
    assert invalid(panda.distances, q, [dict(obstacles[0], name="obstacle1"), unnamed]) == "obstacles[1].name"
    # A needle breaks Property 2 (params.validate, the default, checks every body in a pair).
    needle = {"type": "convex_hull", "points": [[0, 0, 0], [1, 0, 0], [0, 0.01, 0], [0, 0, 0.01]]}
    assert invalid(panda.distances, q, [obstacles[0], needle]) == "obstacles[1]"
    assert panda.distances(q, [obstacles[0], needle], params={"validate": False}).distance.shape == (18,)
    assert panda.distances(q, [obstacles[0], needle], pairs="self").distance.shape == (25,)  # not in a pair
    assert invalid(panda.distances, q, obstacles, threads=-1) == "threads"
    assert invalid(panda.cbf_rows, q, obstacles, threads=1.5) == "threads"
    assert invalid(panda.distances, q, obstacles, metric="manhattan") == "metric"
    assert invalid(panda.distances, q, obstacles, pairs="all") == "pairs"
    assert invalid(panda.distances, q, obstacles, pairs={"self": True, "allow": [["panda_link1", "nope"]]}) == "pairs.allow[0]"
    assert invalid(panda.distances, q, obstacles, pairs={"self": True, "deny": [["panda_link1"]]}) == "pairs.deny[0]"
    assert invalid(panda.distances, q, obstacles, pairs={"allow": [["panda_link1", "panda_link2"]]}) == "pairs.allow"
    assert invalid(panda.distances, q, obstacles, pairs={"self": True, "others": True}) == "pairs.others"
    assert invalid(panda.distances, q, obstacles, params={"h": -1}) == "params.h"
    assert invalid(panda.distances, q, obstacles, params={"gradient": False}) == "params.gradient"
    assert invalid(panda.cbf_rows, q, obstacles, margins={"self": -0.1}) == "margins.self"
    assert invalid(panda.cbf_rows, q, obstacles, margins={"obstacles": 0.1}) == "margins.obstacles"
    assert invalid(panda.cbf_rows, q, obstacles, eta=0) == "eta"
    assert invalid(panda.cbf_rows, q, obstacles, eta_joint=float("nan")) == "eta_joint"
    assert invalid(panda.jacobian, q, "panda_link9") == "link"
    assert invalid(panda.jacobian, q, None, [0, 1]) == "point"
    assert invalid(Robot.load, "nope") == "name"
    assert invalid(Robot.load, "../robots/panda") == "name"
    # a type mismatch is also a TypeError
    with pytest.raises(TypeError):
        panda.distances(q, obstacles, params={"h": "big"})


def test_allow_and_deny_edit_the_self_pairs(panda):
    base = panda.distances(np.zeros(7), [], pairs="self")
    names = base.names
    denied = panda.distances(np.zeros(7), [], pairs={"self": True, "deny": [["panda_link7", "panda_link1"]]})
    assert denied.names == [n for n in names if not (n.startswith("link1_cylinder/") and "link7" in n)]
    assert len(denied.names) == len(names) - 2
    allowed = panda.distances(np.zeros(7), [], pairs={"self": True, "allow": [["panda_link2", "panda_link3"]]})
    assert set(allowed.names) - set(names) == {"link2_cylinder/link3_cylinder"}
    # pairs stay in element order: the allowed pair sits where (1, 2) belongs
    assert allowed.names.index("link2_cylinder/link3_cylinder") == sum(n.startswith("link1_") for n in names)


def test_bad_urdf_names_the_element(meshbot_dir, tmp_path):
    text = meshbot_urdf()
    robot_dir = meshbot_dir / "robot"

    def error(urdf, package_dirs=None, **kw):
        path = robot_dir / "broken.urdf"
        path.write_text(urdf)
        with pytest.raises(distlab.InvalidInput) as info:
            Robot.from_urdf(path, package_dirs=package_dirs, **kw)
        assert info.value.field == "urdf"
        return str(info.value)

    message = error(text)  # no package_dirs
    assert "package \"testpkg\"" in message and "l2_tet" in message
    message = error(text.replace("meshes/box.stl", "meshes/missing.stl"), {"testpkg": str(meshbot_dir / "pkg")})
    assert "missing.stl" in message and "no such file" in message and "l1_stl" in message
    assert f'"{robot_dir / "meshes" / "missing.stl"}"' in message  # where it looked
    message = error(text.replace("meshes/box.stl", "meshes"), {"testpkg": str(meshbot_dir / "pkg")})
    assert "a folder, not a file" in message and "l1_stl" in message
    # The caller's own paths, whole: a package folder, the URDF itself.
    with pytest.raises(distlab.InvalidInput) as info:
        Robot.from_urdf(robot_dir / "meshbot.urdf", {"testpkg": meshbot_dir / "no_such_pkg"})
    assert info.value.field == "package_dirs['testpkg']" and str(meshbot_dir / "no_such_pkg") in str(info.value)
    for missing, why in ((tmp_path / "nowhere.urdf", "no such file"), (tmp_path, "is a folder")):
        with pytest.raises(distlab.InvalidInput) as info:
            Robot.from_urdf(missing)
        assert info.value.field == "urdf" and f'"{missing}"' in str(info.value) and why in str(info.value)
    message = error(text.replace('type="prismatic"', 'type="floating"'), {"testpkg": str(meshbot_dir / "pkg")})
    assert "j2" in message and "floating" in message
    # A mesh with a hole: its hull all the same, with a warning naming it; refused on request.
    (robot_dir / "meshes" / "open.obj").write_text("".join(f"v {x!r} {y!r} {z!r}\n" for x, y, z in TET) +
                                                   "f 1 3 2\nf 1 2 4\nf 1 4 3\n")
    opened = text.replace('"meshes/tet.obj"', '"meshes/open.obj"')
    (robot_dir / "open.urdf").write_text(opened)
    with pytest.warns(UserWarning, match="l4_tet.*not closed"):
        robot = Robot.from_urdf(robot_dir / "open.urdf", {"testpkg": meshbot_dir / "pkg"})
    assert len(robot.warnings) == 1 and "open.obj" in robot.warnings[0]
    closed = Robot.from_urdf(robot_dir / "meshbot.urdf", {"testpkg": meshbot_dir / "pkg"})
    assert closed.warnings == []
    q = np.array([0.2, 0.1, -0.3, 0.5])
    np.testing.assert_array_equal(robot.distances(q, OBSTACLES).distance, closed.distances(q, OBSTACLES).distance)
    message = error(opened, {"testpkg": str(meshbot_dir / "pkg")}, require_closed_meshes=True)
    assert "not closed" in message and "l4_tet" in message
    # Text no XML parser sees: nesting that would overflow TinyXML's stack, an element whose
    # attributes would take it seconds, a DOCTYPE.
    assert "deeper than 64" in error('<robot name="r">' + "<a>" * 100000 + "</a>" * 100000 + "</robot>")
    assert "more than 64 attributes" in error('<robot name="r"><link name="l" ' + 'a="" ' * 70000 + "/></robot>")
    assert "DOCTYPE" in error('<!DOCTYPE r [<!ENTITY x "y">]><robot name="r"/>')


# ---------------------------------------------------------------------------------------------
# Ctrl-C

CHILD = r"""
import os, sys
import numpy as np
from distlab.robot import Robot

# A slider with a ball against a 796-facet hull, GAP's plain iteration: ~150 us per configuration,
# ~80 bytes of answer; 1.5 M of them take minutes.
folder = sys.argv[2]
with open(os.path.join(folder, "slider.urdf"), "w") as f:
    f.write('<robot name="slider"><link name="base"/><joint name="x" type="prismatic"><parent link="base"/>'
            '<child link="cart"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>'
            '<link name="cart"><collision><geometry><sphere radius="0.05"/></geometry></collision></link></robot>')
robot = Robot.from_urdf(os.path.join(folder, "slider.urdf"))
k = np.arange(400) + 0.5
phi, theta = np.arccos(1 - 2 * k / 400), np.pi * (1 + 5 ** 0.5) * k
ball = np.c_[np.cos(theta) * np.sin(phi), np.sin(theta) * np.sin(phi), np.cos(phi)] * 0.3
obstacles = [{"type": "convex_hull", "points": ball.tolist(), "pose": {"position": [0, 0.5, 0]}}]
params = {"validate": False, "solver": "fixed_point"}
small = np.zeros((3, 1))
robot.distances(small, obstacles, params=params)  # the model is built before
q = np.linspace(-1, 1, int(sys.argv[1]))[:, None]
print("started", flush=True)
try:
    robot.distances(q, obstacles, params=params, threads=1, tracking=False)
    outcome = "finished"
except KeyboardInterrupt:
    outcome = "interrupted"
print(outcome, float(robot.distances(small, obstacles, params=params).distance.min()), flush=True)
"""


def test_sigint_stops_a_long_batch(tmp_path):
    """SIGINT while a batch of minutes runs: KeyboardInterrupt within the subprocess's timeout
    (a batch that ignored it would run on and fail the test), and the interpreter computes
    again afterwards."""
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path))
    child = subprocess.Popen([sys.executable, "-c", CHILD, "1500000", str(tmp_path)], stdout=subprocess.PIPE, text=True, env=env,
                             cwd=str(ROOT))
    try:
        assert child.stdout.readline().strip() == "started"
        time.sleep(1.0)  # inside the call by now
        child.send_signal(signal.SIGINT)
        out, _ = child.communicate(timeout=60)
    finally:
        child.kill()
    outcome, distance = out.split()
    assert outcome == "interrupted" and float(distance) > 0
