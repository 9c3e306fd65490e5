"""Writes the notebook of an example script: the scripts are the one source, their notebooks are
generated. The module docstring becomes a markdown cell, a cell sets sys.argv from
$DISTLAB_EXAMPLE_ARGS (so the script's argparse reads it), then each `# %%` section becomes a code
cell (`# %% [markdown]` sections a markdown cell, without the comments' `# `).

  /usr/bin/python3 examples/notebook.py examples/gap_face_to_edge.py build/examples/gap_face_to_edge.ipynb
"""

import ast
import re
import sys

import nbformat


def cells(source: str):
    doc = ast.get_docstring(ast.parse(source))
    if doc:
        yield nbformat.v4.new_markdown_cell(doc)
    sections = re.split(r"^# %%(.*)\n", source, flags=re.M)
    for header, body in zip(sections[1::2], sections[2::2]):
        body = body.strip("\n")
        if "[markdown]" in header:
            yield nbformat.v4.new_markdown_cell("\n".join(re.sub(r"^# ?", "", line) for line in body.splitlines()))
        elif body:
            yield nbformat.v4.new_code_cell(body)


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    with open(sys.argv[1], encoding="utf-8") as f:
        source = f.read()
    # The script's command line, in the notebook: $DISTLAB_EXAMPLE_ARGS (CI runs them small).
    argv = nbformat.v4.new_code_cell(
        "import os, shlex, sys\n"
        f"sys.argv = [{sys.argv[1].rsplit('/', 1)[-1]!r}] + shlex.split(os.environ.get('DISTLAB_EXAMPLE_ARGS', ''))")
    body = list(cells(source))
    nb = nbformat.v4.new_notebook(cells=body[:1] + [argv] + body[1:])
    nb.metadata["kernelspec"] = {"name": "python3", "display_name": "Python 3", "language": "python"}
    nbformat.write(nb, sys.argv[2])


if __name__ == "__main__":
    main()
