"""The OpenAPI document against the real server: every operation it describes is called at least
once with a request that succeeds, and every answer (JSON, msgpack, the WebSocket's text and binary
messages) validates against the schema the served document gives for its status and content type.
A schema and a response that disagree fail here, naming the operation and the offending place.

Validation: python3-jsonschema (Debian), JSON Schema 2020-12, the dialect of OpenAPI 3.1; msgpack
bin fields (OpenAPI `format: binary` strings) are checked as strings. Also the assembly's refusals
(backend/server/openapi_assemble.py): a path defined twice, a reference into another module; and
that it holds exactly the modules src/modules.cpp registers, those GET /api/version lists.
"""

import importlib.util
import json
import os
import pathlib
import re
import shutil
import signal
import subprocess
import tempfile
import threading
import time

import jsonschema
import msgpack
import pytest
import requests
import websocket

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXE = os.environ.get("DISTLAB_EXE", str(ROOT / "build" / "backend" / "app" / "distlab"))


def plain(x):
    """A decoded msgpack value with bin fields as text (what `format: binary` strings stand for)."""
    if isinstance(x, dict):
        return {k: plain(v) for k, v in x.items()}
    if isinstance(x, list):
        return [plain(v) for v in x]
    return x.hex() if isinstance(x, bytes) else x


class Api:
    """Calls the server and checks each answer against the served document; records coverage."""

    def __init__(self, url, doc):
        self.url, self.doc, self.covered = url, doc, set()
        self.headers = {}

    def validate(self, schema, body, where):
        root = {"allOf": [schema], "components": self.doc["components"]}
        errors = sorted(jsonschema.Draft202012Validator(root).iter_errors(body), key=lambda e: list(e.path))
        assert not errors, f"{where}: " + "; ".join(
            f"at {'/'.join(map(str, e.absolute_path)) or '(root)'}: {e.message[:300]}" for e in errors[:5])

    def schema(self, name):
        return {"$ref": f"#/components/schemas/{name}"}

    def call(self, method, template, path=None, **kw):
        kw.setdefault("headers", self.headers)
        op = self.doc["paths"][template][method.lower()]
        if "json" in kw:  # the request the server accepts is one the document accepts
            self.validate(op["requestBody"]["content"]["application/json"]["schema"], kw["json"], f"{method} {template} request")
        r = requests.request(method, self.url + template.format(**(path or {})), timeout=120, **kw)
        where = f"{method} {template} -> {r.status_code}"
        assert 200 <= r.status_code < 300, f"{where}: {r.text[:500]}"
        documented = op["responses"].get(str(r.status_code))
        assert documented is not None, f"{where}: status not documented"
        content = documented.get("content")
        if not content:
            assert r.content == b"", f"{where}: a body the document does not describe"
        else:
            ctype = r.headers.get("Content-Type", "").split(";")[0].strip()
            assert ctype in content, f"{where}: content type {ctype!r}, documented {sorted(content)}"
            if ctype == "application/json":
                body = r.json()
            elif ctype == "application/msgpack":
                body = plain(msgpack.unpackb(r.content))
            else:
                body = r.content.hex()
                assert body, f"{where}: empty {ctype}"
            self.validate(content[ctype]["schema"], body, where)
        self.covered.add((method.lower(), template))
        return r


def wait_job(api, job_id, sid):
    for _ in range(1200):
        job = api.call("GET", "/api/jobs/{id}", {"id": job_id}).json()
        if job["state"] in ("succeeded", "failed", "cancelled"):
            return job
        time.sleep(0.1)
    pytest.fail(f"job {job_id} of session {sid} did not end")


@pytest.fixture(scope="module")
def server():
    with tempfile.TemporaryDirectory() as cache, tempfile.TemporaryDirectory() as web:
        proc = subprocess.Popen([EXE, "serve", "--host", "127.0.0.1", "--port", "0", "--cache-dir", cache, "--web",
                                 web, "--assets", str(ROOT / "assets"), "--threads", "2"], stdout=subprocess.PIPE,
                                text=True)
        m = re.search(r"127\.0\.0\.1:(\d+)", proc.stdout.readline())
        assert m, "no port printed"
        try:
            yield f"127.0.0.1:{m.group(1)}"
        finally:
            proc.send_signal(signal.SIGTERM)
            assert proc.wait(timeout=60) == 0


def test_every_operation_answers_as_documented(server):
    url = f"http://{server}"
    for _ in range(100):
        try:
            doc = requests.get(url + "/api/openapi.json", timeout=10).json()
            break
        except requests.ConnectionError:
            time.sleep(0.05)
    api = Api(url, doc)

    # Core.
    for route in ("/api/health", "/api/version", "/api/openapi.json", "/api/limits"):
        api.call("GET", route)
    sid = api.call("POST", "/api/session").json()["session"]
    api.headers = {"X-Distlab-Session": sid}

    # The WebSocket: every message it sends until the end is checked below.
    ws = websocket.create_connection(f"ws://{server}/ws?session={sid}", timeout=60)
    api.covered.add(("get", "/ws"))
    received, stop = [], threading.Event()

    def read():
        ws.settimeout(0.2)
        while not stop.is_set():
            try:
                opcode, data = ws.recv_data()
            except websocket.WebSocketTimeoutException:
                continue
            except Exception:  # noqa: BLE001  (closed)
                return
            received.append((opcode, data))

    reader = threading.Thread(target=read)
    reader.start()

    def send(msg):
        api.validate(api.schema("WsClientMessage"), msg, f"WebSocket client message {msg['type']}")
        ws.send(json.dumps(msg))

    send({"type": "ping"})
    send({"type": "state"})
    api.call("GET", "/api/session")

    # GAP.
    example = json.loads((ROOT / "assets" / "gap" / "example.json").read_text())
    pair = {k: example[k] for k in ("a", "b")}
    api.call("POST", "/api/gap/distance", json=example)  # validate and gradient on
    api.call("POST", "/api/gap/distance", json={"pairs": [pair, pair]})
    plane = {"center": [0, 0, 0], "normal": [0, 0, 1], "size": [1, 1], "resolution": [8, 8]}
    api.call("POST", "/api/gap/levelsets", json={"shape": example["a"], "grid": {"resolution": 16}, "plane": plane})

    # Kelvin: an upload, an object prepared as a job, its field, σ, levels, frames and export.
    api.call("GET", "/api/kelvin/assets")
    up = api.call("POST", "/api/kelvin/uploads", params={"format": "stl"}, data=(ROOT / "assets" / "cube.stl").read_bytes(),
                  headers={**api.headers, "Content-Type": "application/octet-stream"}).json()
    reused = api.call("POST", "/api/kelvin/uploads/reuse", json={"digest": up["digest"]}).json()
    api.call("GET", "/api/kelvin/uploads/{id}/surface", {"id": up["upload"]})
    api.call("GET", "/api/kelvin/uploads/{id}/defects", {"id": up["upload"]})
    api.call("DELETE", "/api/kelvin/uploads/{id}", {"id": reused["upload"]})
    create = {"asset": "cube", "lx": 0.3}
    api.call("POST", "/api/kelvin/estimate", json=create)
    made = api.call("POST", "/api/kelvin/objects", json=create).json()
    oid = made["object"]["id"]
    assert wait_job(api, made["job"]["id"], sid)["state"] == "succeeded"
    send({"type": "watch", "object": oid, "levels": [0.3]})
    send({"type": "sigma", "object": oid, "sigma": {"constant": 0.2}, "request": "q1"})
    obj = {"id": oid}
    api.call("GET", "/api/kelvin/objects")
    api.call("GET", "/api/kelvin/objects/{id}", obj)
    api.call("GET", "/api/kelvin/objects/{id}/sigma", obj)
    api.call("PUT", "/api/kelvin/objects/{id}/sigma", obj, json={"constant": 0.1})
    api.call("PUT", "/api/kelvin/objects/{id}/levels", obj, json={"levels": [0.3]})
    api.call("POST", "/api/kelvin/objects/{id}/query", obj, json={"points": [[1.0, 0, 0], [0.0, 0, 0]]})
    api.call("GET", "/api/kelvin/objects/{id}/isosurface", obj, params={"level": 0.3})
    api.call("GET", "/api/kelvin/objects/{id}/surface", obj)
    api.call("GET", "/api/kelvin/objects/{id}/export", obj, params={"level": 0.3})

    # CBF: scenarios, the robot, a rollout to its record, a sweep, a cancelled rollout.
    for name in api.call("GET", "/api/cbf/scenarios").json()["scenarios"]:
        api.call("GET", "/api/cbf/scenarios/{name}", {"name": name})
    api.call("GET", "/api/cbf/robot")
    api.call("GET", "/api/cbf/robot", params={"name": "ur5e"})  # 6 joints
    api.call("POST", "/api/cbf/feasibility", json={"scenario": "corridor"})
    run = api.call("POST", "/api/cbf/rollouts", json={"scenario": "corridor", "params": {"duration": 0.3}}).json()
    rid = run["rollout"]["id"]
    send({"type": "cbf_replay", "rollout": rid, "from": 0})
    assert wait_job(api, rid, sid)["state"] == "succeeded"
    api.call("GET", "/api/cbf/rollouts")
    api.call("GET", "/api/cbf/rollouts/{id}", {"id": rid})
    api.call("GET", "/api/cbf/rollouts/{id}/frames", {"id": rid})
    api.call("GET", "/api/cbf/rollouts/{id}/record", {"id": rid})
    # A scenario with a Kelvin field: the job prepares it, the frames and record carry h, and the
    # field's object and iso-surfaces come once.
    wrench = api.call("POST", "/api/cbf/rollouts", json={"scenario": "wrench_grasp", "metric": "euclidean",
                                                         "params": {"duration": 0.1}}).json()["rollout"]["id"]
    assert wait_job(api, wrench, sid)["state"] == "succeeded"
    for route in ("/api/cbf/rollouts/{id}", "/api/cbf/rollouts/{id}/frames", "/api/cbf/rollouts/{id}/record"):
        api.call("GET", route, {"id": wrench})
    api.call("GET", "/api/cbf/rollouts/{id}/fields", {"id": wrench}, params={"levels": "0,0.1"})
    sweep = api.call("POST", "/api/cbf/sweeps", json={"scenario": "corridor", "params": {"duration": 0.2},
                                                      "sweep": {"parameter": "duration", "values": [0.1, 0.2]}}).json()
    assert wait_job(api, sweep["sweep"]["id"], sid)["state"] == "succeeded"
    api.call("GET", "/api/cbf/sweeps/{id}", {"id": sweep["sweep"]["id"]})
    long_run = api.call("POST", "/api/cbf/rollouts", json={"scenario": "corridor"}).json()["rollout"]["id"]
    api.call("POST", "/api/jobs/{id}/cancel", {"id": long_run})
    wait_job(api, long_run, sid)
    api.call("GET", "/api/jobs")

    # Robots: the built-ins, a Panda among boxes (both pair kinds, two configurations), a URDF whose
    # mesh is an upload of this session (the upload route's answer gives its id), without gradients.
    robots = api.call("GET", "/api/robot/robots").json()["robots"]
    panda = next(r for r in robots if r["name"] == "panda")
    box = {"type": "box", "name": "wall", "size": [0.32, 0.08, 0.92], "pose": {"position": [0.52, 0.19, 0.48]}}
    q = [1.0582, -1.3811, 0.3629, -1.9647, -0.959, 1.4881, -0.1534]
    api.call("POST", "/api/robot/distances", json={"robot": "panda", "q": [q, q], "obstacles": [box], "pairs": "both"})
    api.call("POST", "/api/robot/distances", json={"robot": "panda", "q": q, "metric": "euclidean",
                                                   "pairs": {"self": True, "deny": [[panda["links"][1], panda["links"][3]]]}})
    cube = api.call("POST", "/api/kelvin/uploads", params={"format": "stl"}, data=(ROOT / "assets" / "cube.stl").read_bytes(),
                    headers={**api.headers, "Content-Type": "application/octet-stream"}).json()["upload"]
    urdf = ('<robot name="turntable"><link name="base"/><joint name="turn" type="revolute"><parent link="base"/>'
            '<child link="plate"/><axis xyz="0 0 1"/><limit lower="-3" upper="3" velocity="1" effort="1"/></joint>'
            '<link name="plate"><collision><geometry><mesh filename="cube.stl" scale="0.1 0.1 0.1"/></geometry>'
            '</collision></link></robot>')
    api.call("POST", "/api/robot/distances", json={"robot": {"urdf": urdf, "meshes": {"cube.stl": cube}}, "q": [[0.1], [0.2]],
                                                   "obstacles": [{"type": "sphere", "radius": 0.1, "pose": {"position": [1, 0, 0]}}],
                                                   "params": {"gradient": False}})

    # Scene items (a msgpack frame in, relayed to the socket) and a recording's parts, as a page makes them.
    tri = {"kind": "mesh", "positions": bytes(36), "indices": b"\0\0\0\0\1\0\0\0\2\0\0\0",
           "color": [1, 0, 0]}
    frame = {"headers": {**api.headers, "Content-Type": "application/msgpack"}}
    api.call("PUT", "/api/scene/items/{name}", {"name": "tri"}, data=msgpack.packb(tri), **frame)
    api.call("PUT", "/api/scene/items/{name}/pose", {"name": "tri"}, json={"pose": {"position": [0, 0, 1]}})
    api.call("GET", "/api/scene/items")
    api.call("DELETE", "/api/scene/items/{name}", {"name": "tri"})
    api.call("DELETE", "/api/scene/items")
    rec = {"id": api.call("POST", "/api/scene/recordings", json={"view": "gap", "format": "png", "frames": 1}).json()["id"]}
    api.call("PUT", "/api/scene/recordings/{id}/parts/{index}", {**rec, "index": 0}, data=b"\x89PNG",
             headers={**api.headers, "Content-Type": "application/octet-stream"})
    api.call("POST", "/api/scene/recordings/{id}/finish", rec, json={"camera": {"matrix": [1.0] * 16, "width": 4, "height": 3}})
    api.call("GET", "/api/scene/recordings/{id}", rec)
    api.call("GET", "/api/scene/recordings/{id}/parts/{index}", {**rec, "index": 0})
    api.call("DELETE", "/api/scene/recordings/{id}", rec)

    # The WebSocket's messages so far, each against its schema.
    time.sleep(0.5)
    stop.set()
    reader.join()
    ws.close()
    api.call("DELETE", "/api/kelvin/objects/{id}", obj)
    api.call("DELETE", "/api/session")
    kinds = set()
    binary = {"surface": "MeshFrame", "isosurface": "MeshFrame", "surface_sigma": "SurfaceSigmaFrame",
              "scene_item": "SceneItemFrame"}
    for opcode, data in received:
        if opcode == websocket.ABNF.OPCODE_TEXT:
            msg = json.loads(data)
            api.validate(api.schema("WsServerMessage"), msg, f"WebSocket text message {msg.get('type')}")
        else:
            msg = plain(msgpack.unpackb(data))
            assert msg.get("type") in binary, f"undocumented binary message {msg.get('type')}"
            api.validate(api.schema(binary[msg["type"]]), msg, f"WebSocket binary message {msg['type']}")
        kinds.add(msg["type"])
    assert {"hello", "pong", "job", "object", "sigma", "cbf_frames", "surface", "isosurface", "scene_item", "scene_pose",
            "scene_remove", "scene_clear"} <= kinds, kinds

    documented = {(m, p) for p, item in doc["paths"].items() for m in item if m != "parameters"}
    assert documented - api.covered == set(), "operations no answer was checked for"


def load_assembler():
    spec = importlib.util.spec_from_file_location("openapi_assemble", ROOT / "backend/server/openapi_assemble.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_assembly_refuses_a_path_defined_twice_and_a_reference_into_another_module():
    asm = load_assembler()
    parts = asm.fragments()
    doc = asm.assemble(parts)
    assert set(doc["paths"]) == {p for _, f in parts for p in f.get("paths", {})}
    gap = dict(parts)["gap"]
    twice = parts + [("extra", {"paths": {next(iter(gap["paths"])): {}}})]
    with pytest.raises(asm.AssemblyError, match="already defined by gap"):
        asm.assemble(twice)
    reach = parts + [("extra", {"components": {"schemas": {"X": {"$ref": "#/components/schemas/KelvinObject"}}}})]
    with pytest.raises(asm.AssemblyError, match="belongs to the module kelvin"):
        asm.assemble(reach)
    clash = parts + [("extra", {"x-websocket": {"path": "/other"}})]
    with pytest.raises(asm.AssemblyError, match="set twice"):
        asm.assemble(clash)


def test_the_document_holds_exactly_the_registered_modules(server, tmp_path):
    asm = load_assembler()
    served = requests.get(f"http://{server}/api/version", timeout=10).json()["modules"]
    assert sorted(served) == sorted(asm.registered())
    # A copy of the server's tree where kelvin's folder stays but its module is no longer added,
    # and a folder "draft" with an openapi.json that no line registers.
    src = ROOT / "backend/server"
    shutil.copy(src / "openapi_core.json", tmp_path)
    for part in src.glob("src/*/*"):
        if part.name == "openapi.json" or part.name.endswith("_module.hpp"):
            (tmp_path / part.parent.relative_to(src)).mkdir(parents=True, exist_ok=True)
            shutil.copy(part, tmp_path / part.relative_to(src))
    wiring = (src / "src/modules.cpp").read_text(encoding="utf-8")
    assert "service.add<KelvinModule>();" in wiring
    (tmp_path / "src/modules.cpp").write_text(wiring.replace("service.add<KelvinModule>();", ""), encoding="utf-8")
    (tmp_path / "src/draft").mkdir()
    (tmp_path / "src/draft/openapi.json").write_text(json.dumps({"paths": {"/api/draft": {}}}), encoding="utf-8")
    (tmp_path / "src/draft/draft_module.hpp").write_text("class DraftModule {};\n", encoding="utf-8")
    doc = asm.assemble(asm.fragments(tmp_path))
    parts = dict(asm.fragments())
    kept = [name for name in parts if name != "kelvin"]
    expected = {p for name in kept for p in parts[name].get("paths", {})}
    assert set(doc["paths"]) == expected
    assert not set(parts["kelvin"]["paths"]) & set(doc["paths"])
    assert {t["name"] for t in doc.get("tags", [])} == {t["name"] for n in kept for t in parts[n].get("tags", [])}
