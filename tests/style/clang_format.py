#!/usr/bin/env python3
"""Fails when a C++ file is not formatted with the repository's .clang-format.

Reads every .cpp / .hpp under SOURCE_DIR (tests included; not build*/ or hidden folders) and asks
clang-format (`--dry-run --Werror`, the style file found beside the sources) whether it would
change it. Prints each file it would change with clang-format's first complaint and the command
that fixes it; "OK: N files formatted" otherwise. `--self-test` checks that a misformatted file in
a scratch tree is reported and a formatted one is not.
"""
import argparse
import os
import shutil
import subprocess
import sys
import tempfile


def sources(source_dir):
    for root, dirs, files in os.walk(source_dir):
        dirs[:] = sorted(d for d in dirs if not d.startswith(".") and not d.startswith("build"))
        for name in sorted(files):
            if name.endswith((".cpp", ".hpp")):
                yield os.path.join(root, name)


def unformatted(clang_format, paths):
    """(path, first complaint) of every file clang-format would change."""
    bad = []
    for i in range(0, len(paths), 64):
        batch = paths[i:i + 64]
        r = subprocess.run([clang_format, "--style=file", "--dry-run", "--Werror"] + batch,
                           capture_output=True, text=True)
        if r.returncode == 0:
            continue
        first = {}
        for line in r.stderr.splitlines():
            for p in batch:
                if line.startswith(p + ":") and p not in first:
                    first[p] = line[len(p) + 1:]
        if not first:  # clang-format failed for another reason: say so rather than pass
            raise RuntimeError(f"{clang_format} failed: {r.stderr.strip()[:500]}")
        bad += sorted(first.items())
    return bad


def check(source_dir, clang_format):
    paths = list(sources(source_dir))
    bad = unformatted(clang_format, paths)
    for path, why in bad:
        print(f"{os.path.relpath(path, source_dir)}:{why}", file=sys.stderr)
    if bad:
        print(f"{len(bad)} of {len(paths)} files not formatted: run clang-format -i on them "
              f"(CONTRIBUTING.md, \"Formatting\")", file=sys.stderr)
        return 1
    print(f"OK: {len(paths)} files formatted")
    return 0


def self_test(clang_format, style):
    with tempfile.TemporaryDirectory() as d:
        shutil.copy(style, os.path.join(d, ".clang-format"))
        os.makedirs(os.path.join(d, "src"))
        os.makedirs(os.path.join(d, "build-x"))
        with open(os.path.join(d, "src", "good.cpp"), "w") as f:
            f.write("int twice(int x) {\n  return 2 * x;\n}\n")
        with open(os.path.join(d, "src", "bad.hpp"), "w") as f:
            f.write("int  thrice( int x ){return 3*x;}\n")
        with open(os.path.join(d, "build-x", "generated.cpp"), "w") as f:  # not a source
            f.write("int  skipped ;\n")
        paths = list(sources(d))
        names = sorted(os.path.relpath(p, d) for p in paths)
        if names != ["src/bad.hpp", "src/good.cpp"]:
            print(f"self-test: listed {names}", file=sys.stderr)
            return 1
        bad = [os.path.relpath(p, d) for p, _ in unformatted(clang_format, paths)]
        if bad != ["src/bad.hpp"]:
            print(f"self-test: reported {bad}, expected ['src/bad.hpp']", file=sys.stderr)
            return 1
    print("OK: self-test")
    return 0


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source_dir")
    ap.add_argument("--clang-format", default="clang-format")
    ap.add_argument("--self-test", action="store_true")
    a = ap.parse_args()
    exe = shutil.which(a.clang_format)
    if exe is None:
        print(f"{a.clang_format}: not found (deploy/setup.sh installs the clang-format package)", file=sys.stderr)
        return 1
    if a.self_test:
        return self_test(exe, os.path.join(a.source_dir, ".clang-format"))
    return check(a.source_dir, exe)


if __name__ == "__main__":
    sys.exit(main())
