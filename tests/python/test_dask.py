"""The batch calls on a Dask cluster (distlab.batch) against the local calls: cbf.sweep,
gap.distance and kelvin.prepare_many with client= on a LocalCluster of 2 worker processes give the
local results bit for bit (timings aside), in the input's order; progress in the local call's
vocabulary; Ctrl-C, an exception raised by progress and cancel() stop the running tasks (their runs
end far from done); a worker process killed while its task runs is replaced and the result is
still complete and equal to the local one. One cluster for the module, small problems."""

import concurrent.futures
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

import distlab
from distlab import cbf, gap, kelvin
from conftest import ROOT, assert_same

distributed = pytest.importorskip("distributed")

SWEEP_TIMINGS = {"step_us_mean"}
SPHERE = str(ROOT / "assets" / "sphere.stl")  # radius 0.5 at the origin
CUBE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0], [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float) - 0.5
CUBE_F = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                   [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])


@pytest.fixture(scope="module")
def client():
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None,
                                  silence_logs=40) as cluster, distributed.Client(cluster) as c:
        yield c


def same_arrays(ours, local):
    """Every key, None where the local result has None, arrays equal to the last bit."""
    assert set(ours) == set(local)
    for k, v in local.items():
        if v is None:
            assert ours[k] is None, k
            continue
        w = np.asarray(ours[k])
        v = np.asarray(v)
        assert w.dtype == v.dtype and w.shape == v.shape, k
        assert w.tobytes() == v.tobytes(), k


def running_keys(client, batch):
    """The batch's tasks executing on a worker now (the worker's own record of its threads)."""
    threads = client.run(lambda dask_worker: list(dask_worker.active_threads.values()))
    return {w: [k for k in keys if str(k).startswith(batch.id)] for w, keys in threads.items()}


def wait_until_idle(client, batch):
    while any(running_keys(client, batch).values()):
        time.sleep(0.05)


def random_poses(n, seed=0):
    rng = np.random.default_rng(seed)
    q = rng.standard_normal((n, 4))
    return np.hstack([rng.uniform(-0.4, 0.4, (n, 3)), q / np.linalg.norm(q, axis=1, keepdims=True)])


def test_distributed_is_imported_only_for_a_client():
    code = ("import sys, distlab; from distlab import batch, cbf, gap, kelvin; "
            "print(sorted(m for m in sys.modules if m.split('.')[0] in ('dask', 'distributed')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


def test_a_client_must_be_a_dask_client():
    with pytest.raises(TypeError, match="client"):
        gap.distance(gap.Sphere(0.1), None, gap.Sphere(0.1), [1, 0, 0, 1, 0, 0, 0], client="tcp://127.0.0.1:8786")
    with pytest.raises(ValueError, match="client"):
        cbf.sweep("corridor", "duration", [0.1], wait=False)


def test_cbf_sweep_equals_local(client):
    values = [0.002, 0.0005, 0.0002]
    local = cbf.sweep("corridor", "margins.gap.obstacle", values, "gap", {"duration": 0.5})
    events = []
    ours = cbf.sweep("corridor", "margins.gap.obstacle", values, "gap", {"duration": 0.5},
                     progress=lambda stage, f: events.append((stage, f)), client=client)
    assert_same(ours, local, skip=SWEEP_TIMINGS)
    assert [e["index"] for e in ours["entries"]] == [0, 1, 2]
    assert type(ours["values"]) is type(local["values"])
    # The local sweep's vocabulary, aggregated over the tasks: never decreasing, ending complete.
    fractions = [f for _, f in events]
    assert fractions == sorted(fractions) and events[-1] == ("3 of 3 runs done", 1.0)
    assert {s for s, _ in events} <= {f"{k} of 3 runs done" for k in range(4)}


def test_cbf_sweep_on_a_cluster_takes_more_than_16_values(client):
    # Locally a sweep is one request of at most 16 runs; on a cluster each run is its own task.
    values = [0.1 + 0.005 * i for i in range(17)]
    with pytest.raises(distlab.InvalidInput, match="1 to 16"):
        cbf.sweep("corridor", "duration", values)
    ours = cbf.sweep("corridor", "duration", values, client=client)
    local = cbf.sweep("corridor", "duration", values[:16])
    assert_same(ours["entries"][:16], local["entries"], skip=SWEEP_TIMINGS)
    last = cbf.sweep("corridor", "duration", values[16:])["entries"][0]
    last["index"] = 16
    assert_same(ours["entries"][16], last, skip=SWEEP_TIMINGS)
    assert ours["values"].tolist() == values


def test_cbf_bad_value_is_named_as_locally(client):
    values = [0.002, 0.001, -1, 0.003]
    with pytest.raises(distlab.InvalidInput) as local:
        cbf.sweep("corridor", "margins.gap.obstacle", values, params={"duration": 0.2})
    with pytest.raises(distlab.InvalidInput) as ours:
        cbf.sweep("corridor", "margins.gap.obstacle", values, params={"duration": 0.2}, client=client)
    assert local.value.field == "sweep.values[2]"
    assert (ours.value.field, ours.value.message) == (local.value.field, local.value.message)
    # The message names the value already: the error's text says it once (was "sweep.values[2]:
    # sweep.values[2] = -1: …").
    assert str(ours.value) == str(local.value) == local.value.message
    assert str(ours.value).startswith("sweep.values[2] = -1: ") and str(ours.value).count("sweep.values") == 1


@pytest.mark.parametrize("warm", [False, True])
def test_gap_distance_equals_local(client, warm):
    n = 3000
    poses = random_poses(n)
    A, B = gap.Box([0.2, 0.1, 0.15]), gap.Capsule(0.04, 0.1)
    warm_start = None
    if warm:  # a tracked sequence: the next poses from the previous Result
        warm_start = gap.distance(A, None, B, poses, gap.Params(), warm_start=gap.distance(A, None, B, poses))
        poses = poses + [0.001, 0, 0, 0, 0, 0, 0]
    local = gap.distance(A, None, B, poses, warm_start=warm_start)
    events = []
    ours = gap.distance(A, None, B, poses, warm_start=warm_start, client=client, chunk=500,
                        progress=lambda done, total: events.append((done, total)))
    same_arrays(ours, local)
    assert (local["track"] is not None) == warm
    done = [d for d, _ in events]
    assert done == sorted(done) and events[-1] == (n, n) and {t for _, t in events} == {n}


def test_gap_distance_shapes_of_results_as_locally(client):
    A, B = gap.Box([0.2, 0.1, 0.15]), gap.Sphere(0.05)
    one = [0.3, 0.1, 0, 1, 0, 0, 0]
    same_arrays(gap.distance(A, None, B, one, client=client), gap.distance(A, None, B, one))  # scalars
    both = random_poses(700, seed=3)
    same_arrays(gap.distance(A, both, B, both[::-1].copy(), client=client, chunk=256),
                gap.distance(A, both, B, both[::-1].copy()))
    none = np.zeros((0, 7))
    same_arrays(gap.distance(A, None, B, none, client=client), gap.distance(A, None, B, none))


@pytest.mark.parametrize("bad,field", [("nan", "pose_b[1234]"), ("count", "pose_b")])
def test_gap_error_names_the_pair_of_the_whole_batch(client, bad, field):
    poses = random_poses(2000)
    pose_a = None
    if bad == "nan":
        poses[1234, 2] = np.nan
    else:
        pose_a = random_poses(3)
    A, B = gap.Box([0.2, 0.1, 0.15]), gap.Sphere(0.05)
    with pytest.raises(distlab.InvalidInput) as local:
        gap.distance(A, pose_a, B, poses)
    with pytest.raises(distlab.InvalidInput) as ours:
        gap.distance(A, pose_a, B, poses, client=client, chunk=500)
    assert local.value.field == field
    assert (ours.value.field, ours.value.message) == (local.value.field, local.value.message)


@pytest.mark.parametrize("bad,field", [("poses", "pose_b"), ("warm start", "warm_start.witness_a")])
def test_gap_arrays_that_do_not_line_up_are_refused_before_any_task(client, bad, field):
    # A count mismatch was sent as one task and found on a worker; now it is refused here with the
    # local call's error, so even wait=False raises at once (no Batch) and nothing is submitted.
    poses = random_poses(2000)
    A, B = gap.Box([0.2, 0.1, 0.15]), gap.Sphere(0.05)
    pose_a, warm = (random_poses(3), None) if bad == "poses" else (None, gap.distance(A, None, B, poses[:10]))
    with pytest.raises(distlab.InvalidInput) as local:
        gap.distance(A, pose_a, B, poses, warm_start=warm)
    assert local.value.field.startswith(field), local.value
    before = len(client.futures)
    with pytest.raises(distlab.InvalidInput) as ours:
        gap.distance(A, pose_a, B, poses, warm_start=warm, client=client, chunk=500, wait=False)
    assert (ours.value.field, ours.value.message) == (local.value.field, local.value.message)
    assert len(client.futures) == before, "no task was submitted"


def test_a_cancelled_task_leaves_no_failure_in_the_worker_logs(client):
    # A stopped task raised _Stopped, which every worker logged as "Compute Failed" with its
    # traceback on every cancel; it now ends quietly (its batch reads nothing).
    import logging

    def level(n, dask_worker=None):
        logging.getLogger("distributed.worker").setLevel(n)

    client.run(level, logging.WARNING)  # the module's cluster is silenced to ERROR
    try:
        batch = cbf.sweep("corridor", "duration", [600.0, 600.0], client=client, wait=False)
        while not (all(running_keys(client, batch).values()) and batch.progress()[1] > 0):
            time.sleep(0.05)
        batch.cancel()
        wait_until_idle(client, batch)
        time.sleep(0.3)
        logs = [line for records in client.get_worker_logs().values() for _, line in records if batch.id in line]
        assert not [line for line in logs if "_Stopped" in line or "Compute Failed" in line], logs
    finally:
        client.run(level, logging.ERROR)


def test_kelvin_prepare_many_fills_the_cache_as_locally(client, tmp_path):
    meshes = [(CUBE_V, CUBE_F), SPHERE]
    options = {"lx": 0.3}
    local_stats = kelvin.prepare_many(meshes, cache_dir=tmp_path / "local", **options)
    events = []
    ours = kelvin.prepare_many(meshes, cache_dir=tmp_path / "cluster", client=client,
                               progress=lambda stage, f: events.append((stage, f)), **options)
    assert [s["cache_hit"] for s in local_stats] == [s["cache_hit"] for s in ours] == [False, False]
    assert [s["n_verts"] for s in ours] == [s["n_verts"] for s in local_stats]
    fractions = [f for _, f in events]
    assert fractions == sorted(fractions) and events[-1] == ("2 of 2 fields prepared", 1.0)
    # Again: every field is in the shared directory already.
    assert [s["cache_hit"] for s in kelvin.prepare_many(meshes, cache_dir=tmp_path / "cluster", client=client,
                                                        **options)] == [True, True]
    # The fields the workers stored are the ones prepared here, bit for bit: values and gradients
    # at fixed points, after the same sigma, loaded from each directory and prepared afresh.
    points = np.array([[0.8, 0.0, 0.0], [0.5, 0.6, -0.7], [-1.2, 0.1, 0.4], [0.0, 0.0, 2.5]])
    for mesh in meshes:
        answers = []
        for cache in (tmp_path / "local", tmp_path / "cluster", None):
            field = kelvin.Field.prepare(mesh, cache_dir=cache, **options)
            assert field.stats["cache_hit"] == (cache is not None)
            z = field.surface[0][:, 2]
            field.set_sigma(per_vertex=0.05 + 0.1 * (z - z.min()))
            answers.append(field.query(points))
        h, grad, status = answers[0]
        assert (status == 0).all() and np.isfinite(h).all()
        for other in answers[1:]:
            for x, y in zip(answers[0], other):
                assert x.tobytes() == y.tobytes()


def test_kelvin_prepare_many_error_crosses_from_the_worker_naming_the_mesh(client, tmp_path):
    meshes = [(CUBE_V, CUBE_F), (CUBE_V, CUBE_F[:-1])]
    with pytest.raises(distlab.InvalidInput) as local:
        kelvin.prepare_many(meshes, lx=0.3, cache_dir=tmp_path)
    with pytest.raises(distlab.InvalidInput) as ours:
        kelvin.prepare_many(meshes, lx=0.3, cache_dir=tmp_path, client=client)
    assert (ours.value.field, ours.value.message) == (local.value.field, local.value.message)
    assert ours.value.field == "meshes[1]" and ours.value.message.startswith("meshes[1]: "), ours.value
    # A file that is not there: its index and its path (with hundreds of meshes, which one).
    missing = str(tmp_path / "missing.stl")
    with pytest.raises(distlab.InvalidInput) as info:
        kelvin.prepare_many([ROOT / "assets" / "cube.stl", missing], lx=0.3, cache_dir=tmp_path, client=client)
    assert info.value.field == "meshes[1]" and f"meshes[1] ({missing})" in info.value.message, info.value


@pytest.mark.parametrize("how", ["cancel", "sigint", "progress raises"])
def test_cancelling_stops_the_running_tasks(client, how):
    # Runs of 60000 steps (the longest a request may simulate), one waiting for a worker.
    batch = cbf.sweep("corridor", "duration", [600.0, 600.0, 600.0], client=client, wait=False)
    assert len(batch) == 3 and not batch.done()
    # Both workers run a task and reported progress.
    while not (all(running_keys(client, batch).values()) and batch.progress()[1] > 0):
        time.sleep(0.05)
    if how == "cancel":
        batch.cancel()
    elif how == "sigint":  # Ctrl-C while waiting: KeyboardInterrupt cancels before it propagates
        threading.Timer(0.3, os.kill, (os.getpid(), signal.SIGINT)).start()
        with pytest.raises(KeyboardInterrupt):
            batch.wait(lambda stage, fraction: None)
    else:
        def progress(stage, fraction):
            raise RuntimeError("enough")

        with pytest.raises(RuntimeError, match="enough"):
            batch.wait(progress)
    assert batch.cancelled()
    with pytest.raises(concurrent.futures.CancelledError):
        batch.result()
    # The runs stopped where they were: the workers are idle with every run far from its end (a
    # run that went on would have reported fractions near 1 before its worker became idle).
    wait_until_idle(client, batch)
    stage, fraction = batch.progress()
    assert stage == "0 of 3 runs done" and 0 < fraction < 0.5, fraction


def test_a_killed_worker_is_replaced_and_the_result_is_complete(client):
    values = [20.0, 3.0, 3.25, 3.5, 3.75, 4.0]  # simulated seconds: the first run about 0.7 s, the others 0.1 s
    local = cbf.sweep("corridor", "duration", values)
    pids = client.run(os.getpid)
    batch = cbf.sweep("corridor", "duration", values, client=client, wait=False)
    first = f"{batch.id}-0"
    # Kill the worker process running the first run once the runs reported progress.
    while True:
        victim = next((w for w, keys in running_keys(client, batch).items() if first in keys), None)
        if victim is not None and batch.progress()[1] > 0:
            break
        time.sleep(0.02)
    os.kill(pids[victim], signal.SIGKILL)
    assert distributed.Future(first, client).status != "finished"  # it has to run again elsewhere
    ours = batch.wait()
    assert_same(ours, local, skip=SWEEP_TIMINGS)
    # The nanny started a new process in its place (the cluster has two workers again).
    client.wait_for_workers(2)
    assert pids[victim] not in client.run(os.getpid).values()
