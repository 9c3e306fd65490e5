"""Two `distlab serve` replicas over one cache directory behind HAProxy, on loopback, with the
configuration of docker/replicas (haproxy.cfg; the servers listed here): a field prepared through
one replica is a cache hit on the other, a session's requests and WebSocket stay on its replica,
and when that replica stops, distlab.Client re-creates its session, uploads and objects on the
other one from the shared store (issue 35, item 3)."""

import contextlib
import os
import shutil
import socket
import subprocess
import tempfile
import time

import numpy as np
import pytest
import requests

import distlab
from distlab.client import ServiceError
from conftest import ROOT, serving

CONFIG = ROOT / "docker" / "replicas" / "haproxy.cfg"
POINTS = np.array([[0.5, 0.1, 0.0], [0.0, 0.7, 0.2], [-0.4, -0.4, 0.6], [0.9, 0.9, 0.9]])


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def haproxy(replicas):
    """HAProxy on a free loopback port in front of {name: url}; its URL once every replica is up."""
    exe = shutil.which("haproxy") or "/usr/sbin/haproxy"
    assert os.access(exe, os.X_OK), "haproxy is not installed (.ci/packages.txt lists it)"
    with tempfile.TemporaryDirectory() as tmp:
        servers = os.path.join(tmp, "servers.cfg")
        with open(servers, "w") as f:
            f.write("backend replicas\n")
            for name, url in replicas.items():
                f.write(f"    server {name} {url.split('//')[1]} cookie {name}\n")
        port = free_port()
        proc = subprocess.Popen([exe, "-db", "-f", str(CONFIG), "-f", servers],
                                env={**os.environ, "DISTLAB_BIND": f"127.0.0.1:{port}"},
                                stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        url = f"http://127.0.0.1:{port}"
        try:
            seen, end = set(), time.monotonic() + 60
            while seen != set(replicas):  # round robin: every replica answered through HAProxy
                assert proc.poll() is None, proc.stderr.read()
                assert time.monotonic() < end, f"replicas never all answered through HAProxy: {seen}"
                with contextlib.suppress(requests.ConnectionError):
                    r = requests.get(url + "/api/health", timeout=5)
                    if r.ok:
                        seen.add(r.cookies.get("distlab_replica"))
                time.sleep(0.2)
            yield url
        finally:
            proc.terminate()
            proc.wait(timeout=30)


def replica_of(client) -> str:
    return client.http.cookies.get("distlab_replica")


def test_replicas_share_fields_keep_sessions_and_survive_a_stopped_replica(exe, tmp_path):
    store = tmp_path / "store"
    store.mkdir()
    with contextlib.ExitStack() as first, contextlib.ExitStack() as second:
        urls = {"r1": first.enter_context(serving(exe, cache_dir=str(store))),
                "r2": second.enter_context(serving(exe, cache_dir=str(store)))}
        stops = {"r1": first, "r2": second}
        with haproxy(urls) as url:
            a = distlab.Client(url)
            home = replica_of(a)
            assert home in urls
            cube = a.kelvin_object(asset="cube", lx=0.2)
            assert cube.info()["stats"]["cache_hit"] is False
            cube.set_sigma(constant=0.3)
            upload = a.upload(ROOT / "assets" / "sphere.stl")
            sphere = a.kelvin_object(upload=upload, lx_fraction=0.25)
            sphere.set_sigma(axis={"axis": [0, 0, 1], "sigma_nom": 0.5, "width": 0.2})
            h_cube, g_cube, _ = cube.query(POINTS)
            h_sphere, _, _ = sphere.query(POINTS)

            # A client of the other replica finds the field in the shared store.
            others = [distlab.Client(url) for _ in range(3)]
            b = next(c for c in others if replica_of(c) != home)
            assert b.kelvin_object(asset="cube", lx=0.2).info()["stats"]["cache_hit"] is True

            # Sticky: a misrouted request would meet an unknown session and trigger a recovery.
            for _ in range(20):
                np.testing.assert_array_equal(cube.query(POINTS)[0], h_cube)
            with a.live() as live:
                assert live.set_sigma(cube, constant=0.3) > 0
            assert a.recoveries == 0 and replica_of(a) == home

            stops[home].close()  # SIGTERM: the replica and its sessions are gone
            with pytest.warns(RuntimeWarning, match="re-created"):
                h, g, _ = cube.query(POINTS)
            assert a.recoveries == 1 and replica_of(a) != home
            np.testing.assert_array_equal(h, h_cube)  # the same field, the same σ
            np.testing.assert_array_equal(g, g_cube)
            np.testing.assert_array_equal(sphere.query(POINTS)[0], h_sphere)
            assert cube.info()["stats"]["cache_hit"] is True  # from the store, not prepared again
            assert sphere.info()["stats"]["cache_hit"] is True
            with a.live() as live:  # the WebSocket follows the new replica's cookie
                assert live.set_sigma(cube, constant=0.3) > 0

            stranded = distlab.Client(url, session="0" * 32, recover=False)
            with pytest.raises(ServiceError) as e:
                stranded.job("0")
            assert e.value.code == "unknown_session"
