#!/usr/bin/env python3
"""Every route of backend/server is a row of a table (issue 34, route_table.hpp): nothing but
add_routes() gives a route to the Router, and every row names its three parts as
codec(decode, &Owner::handler, encode), whose handler's declaration takes and returns no JSON (a
handler never sees JSON or the Request; decode and encode are the codec's). Exits 1 naming each
offending line; prints the count of rows per file otherwise."""
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1])  # backend/server
sources = sorted(list(root.glob("src/**/*.[ch]pp")) + list(root.glob("include/**/*.hpp")))
table_header = root / "include/distlab/server/route_table.hpp"
row = re.compile(r"codec\(\s*(\w+)\s*,\s*&(\w+)::(\w+)\s*,\s*(\w+)\s*\)")
direct_add = re.compile(r"\b(router_?|router\(\))\s*(\.|->)\s*add\s*\(")

bad, rows = [], {}
declarations = {p: p.read_text(encoding="utf-8") for p in sources}
for path, text in declarations.items():
    rel = path.relative_to(root)
    for n, line in enumerate(text.splitlines(), 1):
        if path != table_header and direct_add.search(line):
            bad.append(f"{rel}:{n}: a route added to the Router directly, not as a row of a table")
    for m in row.finditer(text) if path != table_header else ():
        rows[str(rel)] = rows.get(str(rel), 0) + 1
        owner, handler = m.group(2), m.group(3)
        decl = re.compile(r"^\s*[\w:<>, ]+?\s+" + handler + r"\s*\(([^)]*)\)", re.M)
        found = [(p, d) for p, t in declarations.items() if p.suffix == ".hpp" for d in decl.finditer(t)]
        if not found:
            bad.append(f"{rel}: {owner}::{handler}: no declaration found in a header")
        for p, d in found:
            if re.search(r"\bjson\b|nlohmann", d.group(0)) or re.search(r"\bRequest\b", d.group(1)):
                bad.append(f"{p.relative_to(root)}: {owner}::{handler} sees JSON or the Request: {d.group(0).strip()}")
if not rows:
    bad.append("no table rows found")
for f, k in sorted(rows.items()):
    print(f"{k:3d} rows  {f}")
print("\n".join(bad) if bad else "every route is a row of a table; no handler sees JSON or the Request")
sys.exit(1 if bad else 0)
