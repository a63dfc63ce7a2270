#!/usr/bin/env python3
"""The header rule of docs/architecture.md §1, against the code.

- A header another module includes is public: include/gonio/<module>/.
- A header that another family of the same module, or a test, includes is that module's
  detail: include/gonio/<module>/detail/<family>/, included only by the module and its tests.
- Any other header stays next to its sources (<module>/src/<family>/) and only its family
  includes it.
- No include climbs out of its directory ("../").
"""
import pathlib
import re
import sys

root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else ".").resolve()
modules = sorted(p.parent.name for p in root.glob("*/include/gonio"))
include = re.compile(r'^\s*#\s*include\s+"([^"]+)"', re.M)
errors = []


def owner(path):
    """(module, family) of a file under <module>/src/<family>/, else (top folder, None)."""
    parts = path.relative_to(root).parts
    if len(parts) > 3 and parts[0] in modules and parts[1] == "src":
        return parts[0], parts[2]
    return parts[0], None


for path in sorted(root.glob("*/**/*.[ch]pp")):
    rel = path.relative_to(root)
    if rel.parts[0] in ("build", "web") or "node_modules" in rel.parts:
        continue
    module, family = owner(path)
    for inc in include.findall(path.read_text(errors="replace")):
        if "../" in inc:
            errors.append(f"{rel}: #include \"{inc}\" climbs out of its directory")
            continue
        detail = re.match(r"gonio/([a-z_]+)/detail/", inc)
        if detail and module not in (detail.group(1), "tests"):
            errors.append(f"{rel}: #include \"{inc}\" is {detail.group(1)}'s detail, "
                          f"for {detail.group(1)} and the tests only")
        if inc.startswith("gonio/"):
            continue
        # A header beside sources: "<family>/x.hpp" from <module>/src, or "x.hpp" next to it.
        if module in modules and family is not None:
            target_family = inc.split("/")[0] if "/" in inc else family
            if (root / module / "src" / inc).exists() and target_family != family:
                errors.append(f"{rel}: #include \"{inc}\" reaches into the {target_family} family's "
                              f"sources; a header shared across families belongs in "
                              f"include/gonio/{module}/detail/")

for e in errors:
    print(e)
sys.exit(1 if errors else 0)
