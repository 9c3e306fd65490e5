"""The bytes the server holds for one client address (scene items, recordings) are bounded across
its sessions (max_held_bytes_per_address: 413 too_much_held naming body), and given back when the
items go."""

import numpy as np
import pytest

import distlab
from distlab.client import ServiceError
from conftest import serving

SHARE = 50000  # bytes per address: four items of 1,000 points (12 kB of float32 each), not five


@pytest.fixture(scope="module")
def server(exe):
    with serving(exe, "--threads", "2", "--limit", f"max_held_bytes_per_address={SHARE}", "--limit", "max_scene_items=3") as url:
        yield url


def test_one_address_shares_its_bytes_across_sessions(server):
    points = np.random.default_rng(0).random((1000, 3))
    a, b = distlab.Client(server), distlab.Client(server)
    for i in range(3):
        a.scene.add_points(f"p{i}", points)
    b.scene.add_points("q0", points)
    with pytest.raises(ServiceError) as full:
        b.scene.add_points("q1", points)
    assert (full.value.status, full.value.code, full.value.field) == (413, "too_much_held", "body"), full.value
    assert "max_held_bytes_per_address" in str(full.value)
    a.scene.remove("p0")
    b.scene.add_points("q1", points)
    a.scene.clear()
    b.scene.add_points("q2", points)
    assert sorted(item["name"] for item in b.scene.items()) == ["q0", "q1", "q2"]
