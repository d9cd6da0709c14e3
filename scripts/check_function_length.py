#!/usr/bin/env python3
"""Lists functions longer than a limit in C++ files: the thin-tools rule (docs/architecture.md).

A function is counted from the line that opens its body at the left margin (a definition at
namespace scope, clang-format style) to the closing brace at the left margin. Exit status 1
where one is longer than the limit.

    scripts/check_function_length.py --max-lines 80 tools
"""
import argparse
import os
import re
import sys

OPENER = re.compile(r"^[A-Za-z_].*\)\s*(const\s*)?(override\s*)?(noexcept\s*)?\{\s*$")
NOT_FUNCTION = re.compile(r"^(namespace|class|struct|enum|union|extern)\b")


def functions(path):
    """(name line, first line number, length) of each function defined at the left margin."""
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    i = 0
    while i < len(lines):
        line = lines[i]
        if OPENER.match(line) and not NOT_FUNCTION.match(line):
            start = i
            # A signature may span lines: walk back to the line that starts it.
            while start > 0 and lines[start - 1] and lines[start - 1][0] not in "}/#" and \
                    not lines[start - 1].rstrip().endswith((";", "{", "}")):
                start -= 1
            end = i + 1
            while end < len(lines) and lines[end] != "}":
                end += 1
            yield lines[start].strip(), start + 1, end - start + 1
            i = end
        i += 1


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--max-lines", type=int, default=80)
    parser.add_argument("roots", nargs="+", help="files or folders (their .cc files)")
    args = parser.parse_args()
    paths = []
    for root in args.roots:
        if os.path.isfile(root):
            paths.append(root)
            continue
        for folder, _, names in os.walk(root):
            paths += [os.path.join(folder, n) for n in sorted(names) if n.endswith(".cc")]
    long_ones = []
    for p in sorted(paths):
        for name, line, length in functions(p):
            if length > args.max_lines:
                long_ones.append(f"{p}:{line}: {length} lines: {name}")
    for entry in long_ones:
        print(entry)
    if long_ones:
        print(f"{len(long_ones)} function(s) longer than {args.max_lines} lines", file=sys.stderr)
        return 1
    print(f"no function longer than {args.max_lines} lines in {len(paths)} files")
    return 0


if __name__ == "__main__":
    sys.exit(main())
