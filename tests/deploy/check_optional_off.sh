#!/usr/bin/env bash
# deploy.optional_features_off: the code paths of a build without the optional features still
# compile. A source that tests a `REGOLITH_HAVE_<FEATURE>` macro (MCAP recording, the live server,
# systemd, the SfS height channel of `rocks`, the rendered scenes behind the mock backends and
# `eval sinkage`, ...) is compiled here exactly as this build compiles it (its command from
# compile_commands.json, warnings and -Werror included) but with every -DREGOLITH_HAVE_* removed and
# -fsyntax-only: what a machine without those libraries, or a build configured with the feature
# OFF, would compile. Two such breaks (an unused variable, an include inside a guard) were found by
# hand before this check existed.
#
#   check_optional_off.sh SOURCE_DIR BUILD_DIR
set -euo pipefail
src=$(cd "$1" && pwd)
build=$(cd "$2" && pwd)
db="$build/compile_commands.json"
[[ -f $db ]] || { echo "error: $db not found (configure with CMAKE_EXPORT_COMPILE_COMMANDS=ON)"; exit 1; }

# The sources that test an optional-feature macro, found afresh each run so new ones are covered.
# (The tracked files in a git checkout, otherwise every .cpp outside build directories.)
list_sources() {
  (cd "$src" && git ls-files -- '*.cpp' 2>/dev/null) ||
    (cd "$src" && find . -name '*.cpp' -not -path './build*' -printf '%P\n')
}
mapfile -t files < <(list_sources | (cd "$src" && xargs -r grep -l -E \
  '(ifdef|ifndef|defined\() *REGOLITH_HAVE_|#if +REGOLITH_HAVE_') || true)
[[ ${#files[@]} -gt 0 ]] || { echo "error: no source under $src tests a REGOLITH_HAVE_ macro"; exit 1; }

python3 - "$src" "$db" "${files[@]}" <<'PY'
import json, os, re, shlex, subprocess, sys
src, db, files = sys.argv[1], sys.argv[2], sys.argv[3:]
entries = {os.path.realpath(e["file"]): e for e in json.load(open(db))}
checked, failed = 0, []
for rel in files:
    e = entries.get(os.path.realpath(os.path.join(src, rel)))
    if e is None:
        print(f"skip {rel}: not compiled in this build")
        continue
    args = e["arguments"] if "arguments" in e else shlex.split(e["command"])
    out, skip = [], False
    for a in args:
        if skip:
            skip = False
            continue
        if a in ("-o", "-MF", "-MT", "-MQ"):
            skip = True
            continue
        if a in ("-c", "-MD", "-MMD") or re.match(r"-DREGOLITH_HAVE_\w+", a):
            continue
        out.append(a)
    macros = sorted(set(re.findall(r"REGOLITH_HAVE_\w+", open(os.path.join(src, rel)).read())))
    r = subprocess.run(out + ["-fsyntax-only"], cwd=e["directory"], capture_output=True, text=True)
    checked += 1
    if r.returncode != 0:
        failed.append(rel)
        print(f"FAIL {rel} without {', '.join(macros)}:\n{r.stderr}")
    else:
        print(f"ok   {rel} without {', '.join(macros)}")
if failed:
    print(f"error: {len(failed)} of {checked} sources do not compile with the optional features off: "
          + ", ".join(failed))
    sys.exit(1)
if checked == 0:
    print("error: none of the sources was compiled in this build")
    sys.exit(1)
print(f"OK: {checked} sources compile with the optional features off")
PY
