"""cmake --install into a temporary prefix, then a fresh interpreter (no source or build tree on its
paths, an empty working directory, no $DISTLAB_ASSETS) imports the installed package and uses its
installed assets and CLI."""

import json
import os
import pathlib
import re
import signal
import subprocess
import sys
import time

import requests

from conftest import assert_same

BUILD = os.environ.get("DISTLAB_BUILD_DIR", str(pathlib.Path(__file__).resolve().parents[2] / "build"))
CMAKE = os.environ.get("CMAKE_COMMAND", "cmake")
SITE = os.environ.get("DISTLAB_PYTHON_INSTALL_DIR", "lib/python3/dist-packages")

# Runs in the fresh interpreter; prints one JSON line.
SCRIPT = r"""
import json, os, subprocess, sys
import numpy as np
import distlab
from distlab import cbf, gap, kelvin

def plain(x):
    if isinstance(x, (np.ndarray, np.generic)): return plain(x.tolist())
    if isinstance(x, dict): return {k: plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)): return [plain(v) for v in x]
    return None if isinstance(x, float) and x != x else x

def cli(command, request):
    p = subprocess.run([distlab.executable(), command], input=json.dumps(request), capture_output=True,
                       text=True, check=True)
    return json.loads(p.stdout)

example = json.load(open(os.path.join(distlab.assets_dir, "gap", "example.json")))
kelvin_request = {"mesh": {"asset": "cube"}, "lx": 0.3, "sigma": {"constant": 0.2},
                  "query": [[1.0, 0.2, 0.1], [-0.9, 0.7, 0.3]]}
record = cbf.rollout("corridor", "gap", {"duration": 0.05})
print(json.dumps({
    "module": distlab.__file__, "core": distlab._core.__file__, "assets": distlab.assets_dir,
    "shaders": sorted(os.listdir(distlab.shaders_dir)), "executable": distlab.executable(),
    "gap": plain(gap.solve(example)), "gap_cli": cli("gap", example),
    "kelvin": plain(kelvin.solve(kelvin_request)), "kelvin_cli": cli("kelvin", kelvin_request),
    "cbf_steps": len(record["t"]), "cbf_scenario": record["scenario"]}))
"""


def test_installed_package_works_from_a_fresh_shell(tmp_path):
    prefix = tmp_path / "prefix"
    subprocess.run([CMAKE, "--install", BUILD, "--prefix", str(prefix)], check=True, capture_output=True)
    site = prefix / SITE
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path), "PYTHONPATH": str(site), "PYTHONNOUSERSITE": "1",
           "PYTHONDONTWRITEBYTECODE": "1"}
    proc = subprocess.run([sys.executable, "-c", SCRIPT], cwd=work, env=env, capture_output=True, text=True,
                          timeout=600)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.splitlines()[-1])
    for key in ("module", "core", "assets", "executable"):
        assert pathlib.Path(out[key]).resolve().is_relative_to(prefix.resolve()), (key, out[key])
    assert pathlib.Path(out["assets"]) == prefix / "share" / "distlab" / "assets"
    assert pathlib.Path(out["executable"]) == prefix / "bin" / "distlab"
    assert "scalar_slice.frag" in out["shaders"]
    # The installed module and the installed CLI give the same numbers (the CLI found the cube asset
    # from an unrelated working directory, through its install layout).
    assert_same(out["gap"], out["gap_cli"])
    skip = {"t_mesh", "t_build", "t_decomp", "t_solve", "size_mb"}
    assert_same(out["kelvin"], out["kelvin_cli"], skip=skip)
    assert out["kelvin"]["query"]["h"][0] is not None
    assert out["cbf_steps"] > 1 and out["cbf_scenario"] == "corridor"


def test_installed_server_finds_its_data(tmp_path):
    prefix = tmp_path / "prefix"
    subprocess.run([CMAKE, "--install", BUILD, "--prefix", str(prefix)], check=True, capture_output=True)
    work = tmp_path / "elsewhere"
    work.mkdir()
    env = {"PATH": "/usr/bin:/bin", "HOME": str(tmp_path)}
    proc = subprocess.Popen([str(prefix / "bin" / "distlab"), "serve", "--host", "127.0.0.1", "--port", "0",
                             "--cache-dir", str(tmp_path / "cache")], cwd=work, env=env, stdout=subprocess.PIPE,
                            text=True)
    try:
        line = proc.stdout.readline()
        m = re.search(r"127\.0\.0\.1:(\d+)", line)
        assert m, line
        url = f"http://127.0.0.1:{m.group(1)}"
        for _ in range(100):
            try:
                requests.get(url + "/api/health", timeout=5)
                break
            except requests.ConnectionError:
                time.sleep(0.05)
        # The built-in meshes come from the prefix's share/distlab/assets, as does the front end.
        assets = requests.get(url + "/api/kelvin/assets", timeout=30).json()
        names = {a["name"] if isinstance(a, dict) else a for a in (assets["assets"] if isinstance(assets, dict) else assets)}
        assert {"cube", "sphere"} <= names, assets
        assert f"assets {prefix}/share/distlab/assets" in line, line
        if (prefix / "share" / "distlab" / "web" / "index.html").exists():
            assert f"web {prefix}/share/distlab/web" in line, line
            assert requests.get(url + "/", timeout=30).status_code == 200
    finally:
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=30) == 0
