"""Shared fixtures: the CLI binary next to the built package, and exact comparison of responses."""

import contextlib
import json
import math
import os
import pathlib
import re
import signal
import subprocess
import tempfile

import numpy as np
import pytest

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXE = os.environ.get("DISTLAB_EXE", str(ROOT / "build" / "backend" / "app" / "distlab"))
os.environ.setdefault("DISTLAB_ASSETS", str(ROOT / "assets"))


def run_cli(command, request, *flags):
    """The CLI's response to the same request (JSON text through a pipe)."""
    proc = subprocess.run([EXE, command, *flags], input=json.dumps(request), capture_output=True, text=True,
                          timeout=600, check=False)
    return proc.returncode, json.loads(proc.stdout)


def plain(x):
    """Nested lists/dicts of Python scalars; NaN (a null of the JSON) becomes None."""
    if isinstance(x, (np.ndarray, np.generic)):
        return plain(x.tolist())
    if isinstance(x, dict):
        return {k: plain(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, float) and math.isnan(x):
        return None
    return x


def assert_same(ours, cli, path="", skip=()):
    """Exact equality (doubles to the last bit), numpy arrays against JSON lists."""
    a, b = plain(ours), plain(cli)
    _same(a, b, path, set(skip))


def _same(a, b, path, skip):
    if b is None and isinstance(a, list) and all(v is None for v in a):
        return  # a null row of the JSON is a NaN row of the numpy array
    if isinstance(b, dict):
        assert isinstance(a, dict) and set(a) == set(b), f"{path}: keys {sorted(a)} != {sorted(b)}"
        for k in b:
            if k not in skip:
                _same(a[k], b[k], f"{path}.{k}", skip)
    elif isinstance(b, list):
        assert isinstance(a, list) and len(a) == len(b), f"{path}: {a!r} != {b!r}"
        for i, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{path}[{i}]", skip)
    else:
        assert type(a) in (type(b), int, float) and a == b, f"{path}: {a!r} != {b!r}"
        if isinstance(a, float) or isinstance(b, float):
            assert float(a).hex() == float(b).hex(), f"{path}: {a!r} != {b!r}"


@pytest.fixture(scope="session")
def exe():
    if not os.access(EXE, os.X_OK):
        pytest.fail(f"the distlab CLI is not built at {EXE} (set DISTLAB_EXE)")
    return EXE


@contextlib.contextmanager
def serving(exe, *flags, cache_dir=None):
    """`distlab serve` on a free loopback port with a temporary cache (or ``cache_dir``) and these
    flags: its URL; stopped by SIGTERM afterwards, which must end it cleanly."""
    with (contextlib.nullcontext(cache_dir) if cache_dir else tempfile.TemporaryDirectory()) as cache:
        proc = subprocess.Popen([exe, "serve", "--host", "127.0.0.1", "--port", "0", "--cache-dir", cache,
                                 "--assets", str(ROOT / "assets"), *flags], stdout=subprocess.PIPE, text=True)
        m = re.search(r"127\.0\.0\.1:(\d+)", proc.stdout.readline())
        assert m, "no port printed"
        try:
            yield f"http://127.0.0.1:{m.group(1)}"
        finally:
            proc.send_signal(signal.SIGTERM)
            assert proc.wait(timeout=30) == 0
