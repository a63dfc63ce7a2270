#!/usr/bin/env python3
"""The longest functions of the C++ sources, in lines from the signature to the closing brace.

  python3 tests/repo/function_lengths.py [ROOT] [--top N] [--min LINES]

A reading aid, not a test: functions are found by their braces at namespace or class scope
after comments and literals are blanked, which is right for this code base's style (lambdas
and local classes count toward the function that holds them).
"""
import argparse
import pathlib
import re


def blank(s):
    """Comments, strings and characters replaced by spaces; newlines kept."""
    out, i, n = [], 0, len(s)
    while i < n:
        if s.startswith("//", i):
            j = s.find("\n", i)
            j = n if j < 0 else j
        elif s.startswith("/*", i):
            j = s.find("*/", i + 2)
            j = n if j < 0 else j + 2
        elif (m := re.match(r'R"([^(]*)\(', s[i:i + 20])):
            j = s.find(")" + m.group(1) + '"', i)
            j = n if j < 0 else j + len(m.group(1)) + 2
        elif s[i] in "\"'":
            j = i + 1
            while j < n and s[j] != s[i] and s[j] != "\n":
                j += 2 if s[j] == "\\" else 1
            j += 1
        else:
            out.append(s[i])
            i += 1
            continue
        out.append(re.sub(r"[^\n]", " ", s[i:j]))
        i = j
    return "".join(out)


control = re.compile(r"\b(if|for|while|switch|catch|do|else|try)\b")


def sources(root):
    """The C++ files under root, build trees and dependencies left out."""
    for path in sorted(root.glob("*/**/*.[ch]pp")):
        if not {"build", "node_modules", ".git"} & set(path.relative_to(root).parts):
            yield path


def functions(root):
    """(lines, "path:line", name) of every function in the C++ files under root."""
    found = []
    for path in sources(root):
        found += functions_in(path, root)
    return found


def functions_in(path, root):
    found = []
    s = blank(path.read_text(errors="replace"))
    stack = []  # kinds of the open braces: "scope" (namespace, class), "fn", "other"
    header_start = 0
    fn_start = None
    for i, c in enumerate(s):
        if c == "{":
            header = s[header_start:i]
            h = " ".join(header.split())
            outer_scope = all(k == "scope" for k in stack)
            if re.search(r"\b(namespace|class|struct|union|enum)\b[^()]*$", h) or h.startswith("extern"):
                kind = "scope"
            elif outer_scope and re.search(r"\)\s*(const|noexcept|override|final|mutable|->[^{]*|:[^{]*)*\s*$", h) \
                    and not control.match(h.split("(")[0].split()[-1] if h.split("(")[0].split() else ""):
                kind = "fn"
                start = s.count("\n", 0, header_start + len(header) - len(header.lstrip())) + 1
                fn_start = (start, h.split("(")[0].split()[-1] if h.split("(")[0].split() else "?")
            else:
                kind = "other"
            stack.append(kind)
            header_start = i + 1
        elif c == "}":
            kind = stack.pop() if stack else "other"
            if kind == "fn" and fn_start:
                end = s.count("\n", 0, i) + 1
                found.append((end - fn_start[0] + 1, f"{path.relative_to(root)}:{fn_start[0]}", fn_start[1]))
                fn_start = None
            header_start = i + 1
        elif c == ";" :
            header_start = i + 1
        elif c in ":" and s[i - 1] != ":" and i + 1 < len(s) and s[i + 1] != ":" and \
                re.search(r"\b(public|private|protected)\s*$", s[header_start:i]):
            header_start = i + 1
    return found


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("root", nargs="?", default=".")
    ap.add_argument("--top", type=int, default=15)
    ap.add_argument("--min", type=int, default=0)
    args = ap.parse_args()
    root = pathlib.Path(args.root)
    found = sorted(functions(root), reverse=True)
    for lines, where, name in found[: args.top]:
        if lines >= args.min:
            print(f"{lines:5d}  {name:32s} {where}")


if __name__ == "__main__":
    main()
