#!/usr/bin/env python3
"""Sizes a reader can hold: no source file over 700 lines, no function over 120 lines.

  python3 tests/repo/sizes.py [ROOT]

Source files are the C++, JavaScript, Python and shell files outside the test folders
(tests/, python/tests/, web/test/) and the build trees; functions are the C++ functions of
those files as tests/repo/function_lengths.py finds them. An offender that remains is listed
in sizes_allowed.txt with its current size: it may shrink, not grow, and nothing new may
join it, so the list only gets shorter. Fails naming each file or function over its limit;
an entry within its limit now is named as one to remove.
"""
import pathlib
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from function_lengths import functions_in  # noqa: E402

MAX_FILE_LINES = 700
MAX_FUNCTION_LINES = 120
SUFFIXES = {".cpp", ".hpp", ".h", ".c", ".js", ".mjs", ".py", ".sh"}
SKIP = {"build", "node_modules", ".git", "dist", "tests", "test"}


def allowed(path):
    """{(kind, path, name): lines} from the allowlist: `file PATH LINES` or
    `function PATH NAME LINES`, # comments."""
    out = {}
    for raw in path.read_text().splitlines():
        words = raw.split("#")[0].split()
        if words and words[0] == "file" and len(words) == 3:
            out[("file", words[1], "")] = int(words[2])
        elif words and words[0] == "function" and len(words) == 4:
            out[("function", words[1], words[2])] = int(words[3])
        elif words:
            sys.exit(f"{path.name}: cannot read '{raw}'")
    return out


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else ".").resolve()
    allow = allowed(pathlib.Path(__file__).resolve().parent / "sizes_allowed.txt")
    sizes = {}
    for path in sorted(root.glob("*/**/*")):
        rel = path.relative_to(root)
        if path.suffix not in SUFFIXES or not path.is_file() or SKIP & set(rel.parts[:-1]):
            continue
        lines = path.read_text(errors="replace").count("\n")
        if lines > MAX_FILE_LINES:
            sizes[("file", str(rel), "")] = lines
        if path.suffix in (".cpp", ".hpp"):
            for n, where, name in functions_in(path, root):
                if n > MAX_FUNCTION_LINES:
                    key = ("function", str(rel), name)
                    sizes[key] = max(n, sizes.get(key, 0))
    errors = []
    for (kind, rel, name), n in sorted(sizes.items()):
        what = f"{rel}: {n} lines" if kind == "file" else f"{rel}: {name} is {n} lines"
        limit = MAX_FILE_LINES if kind == "file" else MAX_FUNCTION_LINES
        listed = allow.get((kind, rel, name))
        if listed is None:
            errors.append(f"{what} (at most {limit}: split it)")
        elif n > listed:
            errors.append(f"{what}, grown past the {listed} of sizes_allowed.txt (at most {limit})")
    for key in sorted(set(allow) - set(sizes)):
        print(f"sizes_allowed.txt: '{' '.join(k for k in key if k)}' is within its limit now: "
              f"remove the entry")
    for e in errors:
        print(e)
    return 1 if errors else 0


if __name__ == "__main__":
    sys.exit(main())
