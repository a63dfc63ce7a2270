#!/usr/bin/env python3
"""The daemon's folders and which may use which (docs/architecture.md §5), against the code.

The table is read from the architecture page (the block after <!-- daemon-folders -->), so the
page and this check cannot drift apart. It fails when a folder under daemon/src or
daemon/include/gonio/daemon is missing from the table, when the table names a folder that does
not exist, when a file includes a header of a folder its own folder may not use, and when a
use the table allows is no longer made (the table would then promise more than the code does).
"""
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else ".")
page = (root / "docs/architecture.md").read_text()
m = re.search(r"<!-- daemon-folders -->\n```\n(.*?)\n```", page, re.S)
if not m:
    sys.exit("docs/architecture.md: no <!-- daemon-folders --> block")

# Rows: "name/   what it holds   uses: a b c" (or "uses: —"); a row may run on over several
# lines, and only its first line names the folder.
allowed = {}
column = None  # where a row's first line puts its uses; its other lines continue there
for line in m.group(1).splitlines():
    row = re.match(r"^([a-z_]+)/\s", line)
    if row:
        current = row.group(1)
        allowed[current] = set()
        u = re.search(r"uses: ", line)
        column = u.end() if u else None
    if column is not None:
        allowed[current] |= {w.strip("/,") for w in line[column:].split() if w != "—"}

src = root / "daemon/src"
inc = root / "daemon/include/gonio/daemon"
folders = {p.name for p in src.iterdir() if p.is_dir()} | {p.name for p in inc.iterdir() if p.is_dir()}
errors = []
for f in sorted(folders - allowed.keys()):
    errors.append(f"daemon folder {f}/ is not in the table of docs/architecture.md §5")
for f in sorted(allowed.keys() - folders):
    errors.append(f"the table of docs/architecture.md §5 names {f}/, which does not exist")
for f, uses in allowed.items():
    for u in sorted(uses - allowed.keys()):
        errors.append(f"{f}/ may use {u}/, which is not a folder in the table")

include = re.compile(r'^\s*#\s*include\s+"(?:gonio/daemon/)?([a-z_]+)/[^"]+"', re.M)
used = {f: set() for f in allowed}
for base in (src, inc):
    for path in sorted(base.rglob("*")):
        if path.suffix not in (".cpp", ".hpp") or path.parent == base:
            if path.suffix in (".cpp", ".hpp"):
                errors.append(f"{path.relative_to(root)}: every daemon file belongs to a folder")
            continue
        folder = path.relative_to(base).parts[0]
        for target in include.findall(path.read_text()):
            if target not in folders or target == folder:
                continue  # another module's header (gonio/twin/...), or its own folder
            used.setdefault(folder, set()).add(target)
            if target not in allowed.get(folder, set()):
                errors.append(f"{path.relative_to(root)} includes a header of {target}/, "
                              f"which {folder}/ may not use")
for f, uses in allowed.items():
    for u in sorted(uses - used.get(f, set())):
        errors.append(f"the table lets {f}/ use {u}/, but nothing in {f}/ does")

# One way: the allowed uses must have no cycle.
state = {}
def visit(f, path):
    if state.get(f) == "done":
        return
    if state.get(f) == "open":
        errors.append("the folders' uses form a cycle: " + " -> ".join(path + [f]))
        return
    state[f] = "open"
    for u in sorted(allowed.get(f, ())):
        visit(u, path + [f])
    state[f] = "done"
for f in sorted(allowed):
    visit(f, [])

for e in errors:
    print(e)
sys.exit(1 if errors else 0)
