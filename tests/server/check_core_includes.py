#!/usr/bin/env python3
"""The server's core knows no feature, and a module knows the core only by its public headers:
no core file (backend/server/src/*.{cpp,hpp} and the core headers) includes a feature module's
header or names a type a feature declares (not even forward: a module keeps its per-session state
in its own ModuleState); no module includes a core file from src/; and no feature module includes
another's (the shared codecs are open to every module but not to the core: gap_json.hpp, shapes,
which the CLI, the Python bindings and the CBF scenarios share; kelvin_json.hpp, meshes, σ and
repair requests, which the CBF scenarios' Kelvin fields share). modules.cpp, the wiring, is the one file that
names them all. Exits 1 naming each offending line."""
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1])  # backend/server
include = re.compile(r'^\s*#\s*include\s*[<"]([^>"]+)[>"]')
# The features are the modules the registry wires in (src/modules.cpp: #include "<feature>/..."), so
# a new feature cannot be taken for core; a folder of src/ the registry does not name is reported.
FEATURES = tuple(sorted({m.group(1).split("/")[0] for line in (root / "src/modules.cpp").read_text(encoding="utf-8").splitlines()
                         if (m := include.match(line)) and "/" in m.group(1) and not m.group(1).startswith("distlab/")}))
unwired = [d.name for d in sorted((root / "src").iterdir()) if d.is_dir() and d.name not in FEATURES]
# A feature's public headers (the codecs the CLI and the Python bindings share) live in its folder:
# src/<feature>/include/distlab/server/.
FEATURE_HEADERS = {h.name: f for f in FEATURES for h in (root / "src" / f / "include").rglob("*.hpp")}


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
    return "core"


declaration = re.compile(r"\b(?:struct|class)\s+([A-Za-z_]\w*)\s*(?:[:{]|final\b)")
comment_or_string = re.compile(r'//.*|/\*.*?\*/|"(?:\\.|[^"\\])*"')
files = [p for p in sorted(list(root.glob("src/**/*.[ch]pp")) + list(root.glob("include/**/*.hpp")))
         if p.name != "modules.cpp"]
# The types the features declare (their classes, structs and aliases), which the core must not name.
feature_types = {}
for path in files:
    if owner(path) != "core":
        for name in declaration.findall(comment_or_string.sub("", path.read_text(encoding="utf-8"))):
            feature_types.setdefault(name, owner(path))
feature_name = re.compile(r"\b(" + "|".join(sorted(feature_types)) + r")\b") if feature_types else None

bad = [f"src/{d}: a folder that src/modules.cpp does not wire in as a feature" for d in unwired]
for path in files:
    mine = owner(path)
    for n, line in enumerate(path.read_text(encoding="utf-8").splitlines(), 1):
        if mine == "core" and feature_name and not include.match(line):
            for name in feature_name.findall(comment_or_string.sub("", line)):
                bad.append(f"{path.relative_to(root)}:{n}: core names {name} ({feature_types[name]})")
        m = include.match(line)
        if not m:
            continue
        # A module reaches the core through its public headers (include/), never through src/.
        target = m.group(1)
        if (mine != "core" and "/" not in target and not (path.parent / target).exists()
                and (root / "src" / target).exists()):
            bad.append(f"{path.relative_to(root)}:{n}: {mine} reaches into the core's src/ for {target}")
        f = feature_of(m.group(1), path)
        shared_codec = m.group(1) in ("distlab/server/gap_json.hpp", "distlab/server/kelvin_json.hpp") and mine != "core"
        if f is not None and f != mine and not shared_codec:
            bad.append(f"{path.relative_to(root)}:{n}: {mine} includes {m.group(1)} ({f})")
print("\n".join(bad) if bad else "the core includes no feature header and names no feature type; no module includes another's")
sys.exit(1 if bad else 0)
