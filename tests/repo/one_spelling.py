#!/usr/bin/env python3
"""One spelling in identifiers: `color` (as in colorimetry, colord, CSS and Cairo). Prose in
comments and strings may say colour; the API's point field "colour" is a wire name and keeps
its spelling. Fails on a C++ or JavaScript identifier that spells it `colour`."""
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else ".")
ident = re.compile(r"[A-Za-z_$][A-Za-z0-9_$]*")
errors = []
for path in sorted(p for ext in ("cpp", "hpp", "js", "mjs") for p in root.rglob("*." + ext)):
    if {"node_modules", "build", "dist", ".git"} & set(path.parts):
        continue
    s = path.read_text(errors="replace")
    js = path.suffix in (".js", ".mjs")
    i, n, line = 0, len(s), 1
    while i < n:
        if s.startswith("//", i):
            j = s.find("\n", i)
            i = n if j < 0 else j
        elif s.startswith("/*", i):
            j = s.find("*/", i + 2)
            j = n if j < 0 else j + 2
            line += s.count("\n", i, j)
            i = j
        elif s[i] in "\"'" or (js and s[i] == "`"):
            q, j = s[i], i + 1
            while j < n and s[j] != q and not (s[j] == "\n" and q != "`"):
                j += 2 if s[j] == "\\" else 1
            line += s.count("\n", i, j)
            i = j + 1
        elif m := ident.match(s, i):
            if "colour" in m.group(0).lower():
                errors.append(f"{path.relative_to(root)}:{line}: identifier {m.group(0)} "
                              f"(the code spells it color)")
            i = m.end()
        else:
            line += s[i] == "\n"
            i += 1
for e in errors:
    print(e)
sys.exit(1 if errors else 0)
