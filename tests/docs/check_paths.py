#!/usr/bin/env python3
"""Every file or folder a document names in `code` exists in the tree (issue 34: docs that said
otherwise). A name with a folder must be a tracked path (or a folder holding tracked files), or
the tail of one; a bare file name must be some tracked file's name. Patterns (`routes_<feature>.cpp`,
`*.py`), URLs, API routes and build outputs are not names of the tree and are skipped.
Usage: check_paths.py FILE.md...   (exit 1 and one line per missing name)"""

import re
import subprocess
import sys

EXTENSIONS = ("cpp", "hpp", "h", "ts", "mjs", "js", "py", "pyi", "json", "md", "txt", "cfg", "yml", "yaml",
              "css", "html", "glsl", "stl", "urdf", "sh", "cmake", "in")
PATHLIKE = re.compile(r"^[\w.+-]+(/[\w.+-]+)*/?$")
BUILT = ("build/", "build-asan/", "web/dist", "web/node_modules", "bin/", "share/", "lib/")  # outputs, install prefix


def tracked():
    files = subprocess.run(["git", "ls-files"], capture_output=True, text=True, check=True).stdout.split()
    folders = {f.rsplit("/", i)[0] for f in files for i in range(1, f.count("/") + 1)}
    return set(files), folders, {f.rsplit("/", 1)[-1] for f in files}


def names(text):
    for span in re.findall(r"`([^`\n]+)`", text):
        for token in span.split():
            token = token.strip(",;:()[]'\"")
            if "<" in token or "*" in token or "{" in token or token.startswith(("/", ".", "-", "http")):
                continue
            if any(token.startswith(b) for b in BUILT) or not PATHLIKE.match(token):
                continue
            if token.endswith("/") or ("/" in token and "." not in token.rsplit("/", 1)[-1]):
                yield token, "folder"
            elif token.rsplit(".", 1)[-1] in EXTENSIONS and "." in token:
                yield token, "file"


def main(paths):
    files, folders, basenames = tracked()
    missing = []
    for doc in paths:
        with open(doc, encoding="utf-8") as f:
            text = f.read()
        for token, kind in sorted(set(names(text))):
            t = token.rstrip("/")
            if kind == "folder":
                ok = t in folders or any(d.endswith("/" + t) for d in folders) or t in files
                ok = ok or "/" not in t  # a bare word in code is not a folder name
            elif "/" in t:
                ok = t in files or any(f.endswith("/" + t) for f in files)
            else:
                ok = t in basenames
            if not ok:
                missing.append(f"{doc}: `{token}` names no {kind} of the tree")
    print("\n".join(missing) or f"every path named in {len(paths)} document(s) exists")
    return 1 if missing else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
