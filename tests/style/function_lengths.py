#!/usr/bin/env python3
"""Function lengths of the C++ sources outside tests/ (CONTRIBUTING.md, "Function length").

  function_lengths.py SOURCE_DIR [--max N] [--top K]
  function_lengths.py --self-test

Reads every .cpp / .hpp under SOURCE_DIR except tests/, build*/ and hidden folders, and measures
each function body from the first line of its definition to its closing brace: definitions at
column 0 (free functions, out-of-class members; a signature may span several lines) and at
column 2 (members defined inside a class, lambdas held in a variable). Prints the K longest;
exits 1, naming each one, when a function is longer than N lines (default 150).
"""
import argparse
import os
import re
import sys

CONTROL = re.compile(r"(if|for|while|switch|else|catch|try|do|return)\b")


def definitions(lines, indent):
    """(first line, last line, text of the first line) of each function defined at `indent`."""
    pad = " " * indent
    i = 0
    while i < len(lines):
        line = lines[i]
        head = line[indent:] if line.startswith(pad) else ""
        starts = (line.startswith(pad) and head[:1].isalpha() and not CONTROL.match(head)
                  and not head.startswith(("namespace", "class ", "struct ", "enum ", "union ", "extern ")))
        if starts and "(" in line:
            # the signature runs until a line ending in '{' (a definition) or ';' (a declaration)
            j = i
            while j < len(lines) and j < i + 12:
                text = lines[j].rstrip()
                if text.endswith(";") or (j > i and lines[j].startswith(pad) and lines[j][indent:indent + 1].isalpha()):
                    j = -1
                    break
                if text.endswith("{"):
                    break
                j += 1
            if 0 <= j < len(lines) and lines[j].rstrip().endswith("{") and j < i + 12:
                k = j + 1
                while k < len(lines) and not (lines[k].startswith(pad + "}") and
                                              (indent == 0 or not lines[k].startswith(pad + " "))):
                    k += 1
                if k < len(lines):
                    yield i + 1, k + 1, line.strip()
                    i = k
        i += 1


def self_test():
    """The scan finds bodies of known length in each form it reads (and skips declarations)."""
    body = ["  x += 1;"] * 148
    member = ["    x += 1;"] * 148
    source = (["int declared(int a,", "             int b);",                          # 2 lines, no body
               "static int free_function(int a,", "                         int b) {"] + body + ["}", "",
              "class Widget {", " public:", "  void member(int x) override {"] + member + ["  }",
              "  int short_one() const { return 1; }", "};", "",
              "void holder() {", "  auto lambda = [](int x) {"] + member + ["  };", "}"])
    got = {text.split("(")[0]: last - first + 1
           for indent in (0, 2) for first, last, text in definitions(source, indent)}
    want = {"static int free_function": 151, "void member": 150, "void holder": 152, "auto lambda = []": 150}
    if got != want:
        print(f"self-test FAILED: measured {got}, expected {want}", file=sys.stderr)
        return 1
    print("OK: self-test")
    return 0


def main():
    if sys.argv[1:] == ["--self-test"]:
        return self_test()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("source_dir")
    ap.add_argument("--max", type=int, default=150)
    ap.add_argument("--top", type=int, default=5)
    a = ap.parse_args()
    found = []
    for root, dirs, files in os.walk(a.source_dir):
        rel_root = os.path.relpath(root, a.source_dir)
        dirs[:] = sorted(d for d in dirs if not d.startswith(".") and not d.startswith("build")
                         and not (rel_root == "." and d == "tests"))
        for name in sorted(files):
            if not name.endswith((".cpp", ".hpp")):
                continue
            path = os.path.join(root, name)
            with open(path, encoding="utf-8", errors="replace") as f:
                lines = f.read().split("\n")
            for indent in (0, 2):
                for first, last, text in definitions(lines, indent):
                    found.append((last - first + 1, os.path.relpath(path, a.source_dir), first, text))
    found.sort(key=lambda t: (-t[0], t[1], t[2]))
    print(f"{len(found)} function definitions; the {a.top} longest:")
    for n, path, first, text in found[:a.top]:
        print(f"  {n:4d} lines  {path}:{first}  {text[:80]}")
    over = [f for f in found if f[0] > a.max]
    for n, path, first, text in over:
        print(f"{path}:{first}: {n} lines, over the limit of {a.max}: split it into one function per stage "
              f"(CONTRIBUTING.md, \"Function length\")", file=sys.stderr)
    if over:
        return 1
    print(f"OK: no function over {a.max} lines")
    return 0


if __name__ == "__main__":
    sys.exit(main())
