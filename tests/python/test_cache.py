"""The field store from Python (distlab.cache, Field.prepare(cache_dir=, cache_budget=)) and from
`distlab cache`: two Python processes preparing one field make one preparation and both get it;
ls, verify and gc say the same as the CLI; a budget evicts the least recently used entry."""

import json
import os
import subprocess
import sys
import textwrap
import time

import numpy as np
import pytest

from conftest import EXE, plain
from distlab import InvalidInput, cache, kelvin

CUBE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float) - 0.5
CUBE_F = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                   [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])
POINTS = [[1.0, 0.3, 0.2], [-0.9, 0.8, 0.1], [0.2, -0.3, 1.5]]

# One process of the two-process test: waits for the go, prepares the cube and prints what it got.
# The one that prepares holds its first meshing report until the other reports waiting (at most
# 60 s), so the other certainly finds it preparing however late it is scheduled (a fixed 1.5 s
# sleep, before, was outlasted once on a loaded machine).
CHILD = textwrap.dedent("""
    import json, os, sys, time
    import numpy as np
    from distlab import kelvin
    V = np.array(json.loads(sys.argv[2])); F = np.array(json.loads(sys.argv[3]))
    open(sys.argv[4] + ".ready", "w").close()
    while not os.path.exists(sys.argv[5]):
        time.sleep(0.001)
    stages = []
    waiting = sys.argv[5] + ".waiting"
    def progress(stage, fraction):
        if stage == "wait":
            open(waiting, "w").close()
        if stage == "mesh" and "mesh" not in stages:
            end = time.monotonic() + 60
            while not os.path.exists(waiting) and time.monotonic() < end:
                time.sleep(0.001)
        stages.append(stage)
    f = kelvin.Field.prepare((V, F), lx=0.3, cache_dir=sys.argv[1], progress=progress)
    f.set_sigma(constant=0.2)
    h = f.query(json.loads(sys.argv[6]))[0]
    json.dump({"hit": f.stats["cache_hit"], "t_wait": f.stats["t_wait"], "waited": "wait" in stages,
               "h": [float(x).hex() for x in h]}, open(sys.argv[4], "w"))
""")


def cli(*args):
    proc = subprocess.run([EXE, "cache", *args], capture_output=True, text=True, timeout=120, check=False)
    return proc.returncode, proc.stdout, proc.stderr


def test_two_processes_prepare_one_field_once(tmp_path):
    store, go = tmp_path / "store", tmp_path / "go"
    outs = [tmp_path / f"out{i}" for i in range(2)]
    procs = [subprocess.Popen([sys.executable, "-c", CHILD, str(store), json.dumps(CUBE_V.tolist()),
                               json.dumps(CUBE_F.tolist()), str(out), str(go), json.dumps(POINTS)])
             for out in outs]
    deadline = time.monotonic() + 60
    while not all(os.path.exists(f"{o}.ready") for o in outs) and time.monotonic() < deadline:
        time.sleep(0.01)
    go.write_text("go")
    assert [p.wait(timeout=120) for p in procs] == [0, 0]
    got = [json.loads(o.read_text()) for o in outs]
    assert sorted(g["hit"] for g in got) == [False, True]  # one preparation
    waiter = next(g for g in got if g["hit"])
    assert waiter["waited"] and waiter["t_wait"] > 0
    assert got[0]["h"] == got[1]["h"]  # the same field, bit for bit
    listing = cache.ls(store)
    assert len(listing["entries"]) == 1 and not listing["leases"] and not listing["temporaries"]


def test_ls_verify_gc_as_the_cli(tmp_path):
    store = tmp_path / "store"
    fields = {lx: kelvin.Field.prepare((CUBE_V, CUBE_F), lx=lx, cache_dir=store) for lx in (0.3, 0.4)}
    listing = cache.ls(store)
    assert json.loads(cli("ls", "--dir", str(store), "--json")[1]) == plain(listing)
    assert sorted(e["lx"] for e in listing["entries"]) == [0.3, 0.4]
    for e in listing["entries"]:
        assert e["current"] and e["surface_faces"] == 12 and e["n_verts"] == fields[e["lx"]].stats["n_verts"]
    assert listing["bytes"] == sum(e["bytes"] for e in listing["entries"])
    code, table, _ = cli("ls", "--dir", str(store))
    assert code == 0 and "2 entries" in table

    assert cache.verify(store)["ok"] == 2
    # One entry damaged: verify names it (exit 1), --fix removes it.
    older = min(listing["entries"], key=lambda e: e["lx"])
    path = store / f"{older['name']}.kelvin"
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0x01
    path.write_bytes(bytes(data))
    code, out, _ = cli("verify", "--dir", str(store), "--json")
    assert code == 1
    report = json.loads(out)
    assert (report["ok"], report["bad"]) == (1, 1)
    assert {e["name"]: e["status"] for e in report["entries"]}[older["name"]] == "bad_mac"
    fixed = cache.verify(store, fix=True)
    assert fixed["removed"] == 1 and not path.exists()
    assert cli("verify", "--dir", str(store))[0] == 0

    # gc: the least recently used goes for the budget; the one left fits it.
    kelvin.Field.prepare((CUBE_V, CUBE_F), lx=0.3, cache_dir=store)
    entries = {e["lx"]: e for e in cache.ls(store)["entries"]}
    os.utime(store / f"{entries[0.3]['name']}.kelvin", (time.time() - 500, time.time() - 500))
    os.utime(store / f"{entries[0.4]['name']}.kelvin", (time.time() - 400, time.time() - 400))
    report = cache.gc(store, budget=entries[0.4]["bytes"])
    assert report["evicted"] == [entries[0.3]["name"]]
    assert report["bytes_after"] == entries[0.4]["bytes"]
    code, out, _ = cli("gc", "--dir", str(store), "--budget", "1", "--keep-recent", "0", "--json")
    assert code == 0 and json.loads(out)["evicted"] == [entries[0.4]["name"]]
    assert cache.ls(store)["entries"] == []


def test_prepare_with_a_budget_evicts(tmp_path):
    store = tmp_path / "store"
    kelvin.Field.prepare((CUBE_V, CUBE_F), lx=0.3, cache_dir=store)
    old = cache.ls(store)["entries"][0]
    os.utime(store / f"{old['name']}.kelvin", (time.time() - 500, time.time() - 500))
    f = kelvin.Field.prepare((CUBE_V, CUBE_F), lx=0.4, cache_dir=store, cache_budget=old["bytes"])
    assert not f.stats["cache_hit"]
    assert [e["lx"] for e in cache.ls(store)["entries"]] == [0.4]
    with pytest.raises(InvalidInput) as e:
        kelvin.Field.prepare((CUBE_V, CUBE_F), lx=0.4, cache_budget=100)
    assert e.value.field == "cache_budget"
    with pytest.raises(InvalidInput) as e:
        kelvin.Field.prepare((CUBE_V, CUBE_F), lx=0.4, cache_dir=store, cache_budget=0.5)
    assert e.value.field == "cache_budget"


def test_bad_input_names_the_option(tmp_path):
    with pytest.raises(InvalidInput) as e:
        cache.ls(tmp_path / "absent")
    assert e.value.field == "dir"
    for args, option in [(["gc", "--dir", str(tmp_path), "--budget", "lots"], "--budget"),
                         (["gc", "--dir", str(tmp_path), "--budget", "0"], "--budget"),
                         (["gc", "--dir", str(tmp_path), "--keep-recent", "-1"], "--keep-recent"),
                         (["ls", "--dir", str(tmp_path / "absent")], "--dir"),
                         (["ls", "--dir"], "--dir"),
                         (["ls", "--fix"], "--fix"),
                         (["tidy"], "tidy")]:
        code, _, err = cli(*args)
        assert code == 2 and option in err, (args, err)
    code, out, _ = cli("gc", "--dir", str(tmp_path), "--budget", "1.5G", "--json")
    assert code == 0 and json.loads(out)["budget"] == 1.5 * 2**30
