#!/usr/bin/env python3
"""Functions declared in a header and named nowhere else: dead code, which the tests keep out.

  python3 tests/repo/unused_functions.py [ROOT]

Every function or member function declared in a header of the C++ sources (*/include/**.hpp,
*/src/**.hpp) must be named somewhere other than where it is declared or defined: in a call,
a pointer taken, a test. Names are compared as identifiers in the C++ files of the whole
repository (sources, tests, benchmarks, fuzz targets) after comments and string literals are
blanked, so a name used only in a comment does not count, and a name shared with another
function that is used hides both (the check errs towards silence). Functions in an unnamed
namespace or `static` in a .cpp are left to the compiler (-Wunused-function).
Fails listing each unused function with where it is declared, unless ALLOWED names it.
"""
import collections
import pathlib
import re
import sys

sys.path.insert(0, str(pathlib.Path(__file__).resolve().parent))
from function_lengths import blank  # noqa: E402

# Names that are used without being spelled out in this repository, each with the reason.
ALLOWED = {
    # Customisation points found by argument-dependent lookup or by a template's name
    # lookup: nlohmann::json's conversions, fmt's formatter, range-for, std::exception.
    "to_json": "nlohmann::json conversion (ADL)",
    "from_json": "nlohmann::json conversion (ADL)",
    "parse": "fmt::formatter",
    "format": "fmt::formatter",
    "begin": "range-for",
    "end": "range-for",
    "what": "std::exception",
    "hash": "std::hash specialisation",
    # Entry points the linker or a runtime calls.
    "main": "program entry",
    "LLVMFuzzerTestOneInput": "libFuzzer entry",
}

KEYWORDS = {
    "if", "for", "while", "switch", "catch", "return", "sizeof", "alignof", "decltype",
    "static_assert", "noexcept", "throw", "new", "delete", "case", "using", "typedef",
    "template", "operator", "requires", "explicit", "alignas", "co_return", "co_await",
}
ident = re.compile(r"[A-Za-z_]\w*")
call = re.compile(r"\b([A-Za-z_]\w*)\s*\(")


def is_declaration(text, start):
    """Whether the name at `start` (followed by '(') is declared or defined there: the
    statement before it is a type (with qualifiers), possibly ending in `Class::`."""
    i = start
    while i > 0 and text[i - 1] not in ";{}":
        i -= 1
    prefix = text[i:start]
    # Access specifiers and attributes end a statement too.
    prefix = re.sub(r"^.*\b(public|private|protected)\s*:(?!:)", "", prefix, flags=re.S)
    prefix = re.sub(r"\[\[[^\]]*\]\]", " ", prefix)
    prefix = re.sub(r"template\s*<[^;{}]*?>\s*(?=\w)", " ", prefix, flags=re.S)
    p = " ".join(prefix.split())
    # A definition out of its class or namespace names them (`void Link::close(`); a call
    # may too (`db::audit_in(`): what decides is a type before them.
    p = re.sub(r"(\b\w+\s*(<[^<>]*>)?\s*::\s*)+$", "", p).strip()
    if not p or re.search(r"[()=.,?]|(?<!:):(?!:)|->|\b(return|new|throw|case|else|do|co_yield|goto)\b", p):
        return False
    words = ident.findall(p)
    if not words or words[-1] in KEYWORDS or words == ["friend"]:
        return False
    return bool(re.search(r"(\w|>|\*|&)$", p))


def main():
    root = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else ".")
    files = []
    for path in sorted(root.glob("*/**/*")):
        if path.suffix not in (".cpp", ".hpp", ".h", ".c") or not path.is_file():
            continue
        if {"build", "node_modules", ".git", "dist"} & set(path.relative_to(root).parts):
            continue
        files.append((path.relative_to(root), blank(path.read_text(errors="replace"))))

    uses = collections.Counter()  # name -> occurrences that are not declarations
    declared = {}  # name -> first header declaration
    for rel, text in files:
        decl_at = set()
        header = rel.suffix == ".hpp" and ("include" in rel.parts or "src" in rel.parts)
        for m in call.finditer(text):
            if is_declaration(text, m.start(1)):
                decl_at.add(m.start(1))
                name = m.group(1)
                if header and name not in declared and not name.isupper() \
                        and "tests" not in rel.parts[:1]:
                    line = text.count("\n", 0, m.start(1)) + 1
                    declared[name] = f"{rel}:{line}"
        for m in ident.finditer(text):
            if m.start() not in decl_at:
                uses[m.group()] += 1

    unused = sorted((where, name) for name, where in declared.items()
                    if uses[name] == 0 and name not in ALLOWED and name not in KEYWORDS)
    for where, name in unused:
        print(f"{where}: {name} is declared but never used (remove it, or say in ALLOWED why "
              f"it is used without its name)")
    return 1 if unused else 0


if __name__ == "__main__":
    sys.exit(main())
