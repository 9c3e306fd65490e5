#!/usr/bin/env python3
"""The server's core knows no feature: no core file (backend/server/src/*.{cpp,hpp} and the core
headers) includes a feature module's header, and no feature module includes another's (the shape
codec gap_json.hpp, which the CLI, the Python bindings and the CBF scenarios share, is open to every
module but not to the core). modules.cpp, the wiring, is the one file that names them all.
Exits 1 naming each offending line."""
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1])  # backend/server
FEATURES = ("gap", "kelvin", "cbf")
# Public headers that belong to a feature (the codecs the CLI and the Python bindings share).
FEATURE_HEADERS = {"gap_json.hpp": "gap", "kelvin_json.hpp": "kelvin", "kelvin_objects.hpp": "kelvin",
                   "cbf_json.hpp": "cbf", "cbf_rollouts.hpp": "cbf"}
include = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]')


def feature_of(target: str, including: pathlib.Path):
    name = pathlib.PurePosixPath(target)
    if str(name.parent) == "distlab/server" and name.name in FEATURE_HEADERS:
        return FEATURE_HEADERS[name.name]
    for f in FEATURES:  # a module's private header: "cbf/cbf_module.hpp", or a sibling in its folder
        if target.startswith(f + "/") or (including.parent.name == f and (including.parent / target).exists()):
            return f
    return None


def owner(path: pathlib.Path):
    rel = path.relative_to(root)
    if rel.parts[0] == "src" and len(rel.parts) > 2 and rel.parts[1] in FEATURES:
        return rel.parts[1]
    if rel.parts[0] == "include" and path.name in FEATURE_HEADERS:
        return FEATURE_HEADERS[path.name]
    return "core"


bad = []
for path in sorted(list(root.glob("src/**/*.[ch]pp")) + list(root.glob("include/**/*.hpp"))):
    if path.name == "modules.cpp":
        continue
    mine = owner(path)
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        m = include.match(line)
        if not m:
            continue
        f = feature_of(m.group(1), path)
        shared_codec = m.group(1) == "distlab/server/gap_json.hpp" and mine != "core"
        if f is not None and f != mine and not shared_codec:
            bad.append(f"{path.relative_to(root)}:{n}: {mine} includes {m.group(1)} ({f})")
print("\n".join(bad) if bad else "the core includes no feature header; no module includes another's")
sys.exit(1 if bad else 0)
