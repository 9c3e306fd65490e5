#!/usr/bin/env python3
"""Assemble the service's OpenAPI document from the core's part and the feature modules' parts.

The core owns openapi_core.json (version, limits, sessions, jobs, errors, the shapes the features
share, the WebSocket messages the core answers); each module folder src/<feature>/ owns its
openapi.json (its paths, schemas, WebSocket messages, tags). Only the modules src/modules.cpp
registers are assembled (a folder whose module is not added there serves nothing, so documents
nothing). The document served at
/api/openapi.json (embedded by CMake) and the one web/scripts/api_types.mjs generates the
TypeScript types from are this script's output, so both read the same assembly.

Rules, checked (any violation exits non-zero naming the fragment and the place):
- a path or a components entry is defined by one fragment only;
- a module refers to the core's components and its own, never to another module's;
- a module adds to a core schema only through "x-extends": {"schemas": {name: partial}}, merged
  into the core's schema: objects merge, arrays append, a value set twice is an error;
- the other top-level members (tags, x-websocket) merge by the same rule.

Usage: openapi_assemble.py [--out FILE] [--cpp FILE]; without --out the document goes to stdout.
"""
import argparse
import copy
import json
import re
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
DEFINED = ("paths", "components")  # members whose entries are defined once, never merged
REF = re.compile(r'"#/components/(\w+)/([^"]+)"')


class AssemblyError(Exception):
    pass


def registered(root=HERE):
    """The module folders src/modules.cpp registers: those of its included headers that declare a
    class it adds (`service.add<Class>()`)."""
    wiring = (root / "src" / "modules.cpp").read_text(encoding="utf-8")
    added = set(re.findall(r"^\s*service\.add<(\w+)>", wiring, re.M))
    folders = set()
    for folder, header in re.findall(r'^#include "(\w+)/(\w+\.hpp)"', wiring, re.M):
        text = (root / "src" / folder / header).read_text(encoding="utf-8")
        declared = re.findall(r"^(?:class|struct) (\w+)", text, re.M)
        folders.update(folder for name in declared if name in added)
    return folders


def fragments(root=HERE):
    """(name, document) of the core and each registered module folder with an openapi.json, in
    folder order."""
    found = [("core", root / "openapi_core.json")]
    modules = registered(root)
    found += [(p.parent.name, p) for p in sorted((root / "src").glob("*/openapi.json")) if p.parent.name in modules]
    return [(name, json.loads(path.read_text(encoding="utf-8"))) for name, path in found]


def merge(dst, src, where):
    for key, value in src.items():
        at = f"{where}/{key}"
        if key not in dst:
            dst[key] = value
        elif isinstance(dst[key], dict) and isinstance(value, dict):
            merge(dst[key], value, at)
        elif isinstance(dst[key], list) and isinstance(value, list):
            dst[key] = dst[key] + value
        else:
            raise AssemblyError(f"{at} is set twice")


def assemble(parts):
    parts = copy.deepcopy(parts)  # the merge shares and extends the parts' objects
    doc = {}
    owner = {}  # "paths/<p>" or "<section>/<name>" -> fragment that defines it
    for name, frag in parts:
        for key, value in frag.items():
            if key == "paths":
                entries = [("paths", p) for p in value]
            elif key == "components":
                entries = [(section, n) for section, items in value.items() for n in items]
            else:
                continue
            for entry in entries:
                if entry in owner:
                    raise AssemblyError(f"{name}: {'/'.join(entry)} is already defined by {owner[entry]}")
                owner[entry] = name
    for name, frag in parts:
        text = json.dumps(frag)
        for section, target in REF.findall(text):
            home = owner.get((section, target))
            if home is None:
                raise AssemblyError(f"{name}: #/components/{section}/{target} is not defined")
            if home not in ("core", name):
                raise AssemblyError(f"{name}: refers to {target}, which belongs to the module {home}")
        for key, value in frag.items():
            if key == "x-extends":
                continue
            if key in DEFINED:
                for section, items in (value.items() if key == "components" else [(None, value)]):
                    into = doc.setdefault(key, {})
                    into = into.setdefault(section, {}) if section else into
                    into.update(items)
            else:
                merge(doc, {key: value}, name)
    for name, frag in parts:
        for section, items in frag.get("x-extends", {}).items():
            for target, partial in items.items():
                if owner.get((section, target)) != "core":
                    raise AssemblyError(f"{name}: x-extends/{section}/{target}: only the core's components can be extended")
                merge(doc["components"][section][target], partial, f"{name}: x-extends/{section}/{target}")
    names = [t["name"] for t in doc.get("tags", [])]
    if len(names) != len(set(names)):
        raise AssemblyError(f"a tag is declared twice: {names}")
    return doc


CPP = """// Generated by backend/server/openapi_assemble.py (the core's and the modules' openapi.json): do not edit.
#include <string>

namespace distlab::server {{

const std::string& openapi_text() {{
  static const std::string text = R"distlab_openapi({text})distlab_openapi";
  return text;
}}

}}  // namespace distlab::server
"""


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", help="write the document here (default: stdout)")
    parser.add_argument("--cpp", help="also write the C++ source that embeds it")
    args = parser.parse_args()
    try:
        doc = assemble(fragments())
    except AssemblyError as e:
        sys.exit(f"openapi_assemble: {e}")
    text = json.dumps(doc, indent=1, ensure_ascii=False) + "\n"
    if args.out:
        Path(args.out).write_text(text, encoding="utf-8")
    else:
        sys.stdout.write(text)
    if args.cpp:
        Path(args.cpp).write_text(CPP.format(text=text), encoding="utf-8")


if __name__ == "__main__":
    main()
