#!/usr/bin/env bash
# deploy.package: build the Debian package with CPack from this build tree and check it.
#   1. dpkg-deb -I / -e: name, architecture, Depends resolved by dpkg-shlibdeps from Debian's
#      libraries (OpenCV, yaml-cpp, Cyclone DDS, libcamera), conffiles, maintainer scripts;
#   2. dpkg-deb -c: exactly the files a rover needs (tool, /etc/regolith deployments, unit, docs,
#      man page) and nothing from the developer install (no headers, static libraries, /usr/local);
#   3. lintian: no error (warnings and infos are printed for the report);
#   4. the package extracted into a throw-away root (dpkg -x: no maintainer scripts, no root
#      needed, seconds instead of the minutes of a debootstrap): the extracted /usr/bin/regolith
#      runs `--help` and `config check` on every extracted /etc/regolith deployment, and a missing
#      deployment file fails with exit status 2 and a message naming it. The run-time libraries
#      are the build machine's, which are the ones the Depends line names.
#   check_package.sh BUILD_DIR
set -euo pipefail
build=$(cd "$1" && pwd)
fail() { echo "FAIL: $*" >&2; exit 1; }
for tool in cpack dpkg-deb dpkg-shlibdeps lintian; do
  command -v "$tool" >/dev/null || fail "$tool not found (Debian packages: cmake, dpkg-dev, lintian)"
done

work=$build/deploy-check
rm -rf "$work"
mkdir -p "$work"
(cd "$work" && cpack --config "$build/CPackConfig.cmake" -B "$work/pkg" >"$work/cpack.log" 2>&1) ||
  { cat "$work/cpack.log"; fail "cpack failed"; }
debs=("$work"/pkg/regolith_*.deb)
[[ -f ${debs[0]} && ${#debs[@]} -eq 1 ]] || fail "expected one regolith_*.deb in $work/pkg, got: ${debs[*]}"
deb=${debs[0]}
echo "package: $(basename "$deb") ($(du -k "$deb" | cut -f1) KiB)"

# ---- 1. control -----------------------------------------------------------------------------------
info=$(dpkg-deb -I "$deb")
field() { dpkg-deb -f "$deb" "$1"; }
[[ $(field Package) == regolith ]] || fail "Package: $(field Package)"
[[ $(field Architecture) == "$(dpkg --print-architecture)" ]] || fail "Architecture: $(field Architecture)"
depends=$(field Depends)
echo "Depends: $depends"
# (libsystemd0 appears once `regolith run` uses SystemdNotifier: --as-needed drops it until then.)
deps=$(sed 's/ ([^)]*)//g; s/, /\n/g' <<<"$depends")
for lib in adduser libc6 libstdc++6 libgcc-s1 libopencv-core406 libopencv-imgproc406 libopencv-imgcodecs406 \
           libyaml-cpp0.7 libddsc0debian libcamera0.0.3 libfmt9; do
  grep -qxF "$lib" <<<"$deps" || fail "Depends lacks $lib"
done
grep -q '/usr/local' <<<"$info" && fail "control mentions /usr/local"
mkdir -p "$work/control"
dpkg-deb -e "$deb" "$work/control"
expected_conffiles=$'/etc/default/regolith\n/etc/regolith/mock_rover.yaml\n/etc/regolith/smart_rover.yaml\n/etc/regolith/wheel_leg_bench.yaml'
[[ $(sort "$work/control/conffiles") == "$expected_conffiles" ]] ||
  fail "conffiles: $(cat "$work/control/conffiles")"
for s in postinst prerm postrm; do
  [[ -x $work/control/$s ]] || fail "$s missing or not executable"
  sh -n "$work/control/$s" || fail "$s: shell syntax"
done
grep -q 'adduser --system' "$work/control/postinst" || fail "postinst does not create the system user"
grep -q 'adduser --quiet regolith video' "$work/control/postinst" || fail "postinst does not add regolith to video"
grep -q 'deluser --system' "$work/control/postrm" || fail "postrm does not remove the system user on purge"

# ---- 2. contents ----------------------------------------------------------------------------------
dpkg-deb -c "$deb" | awk '{print $6}' | sed 's|^\./|/|; s|/$||' | sort >"$work/contents.txt"
for f in /usr/bin/regolith /etc/regolith/mock_rover.yaml /etc/regolith/smart_rover.yaml \
         /etc/regolith/wheel_leg_bench.yaml /etc/default/regolith /lib/systemd/system/regolith.service /usr/lib/sysctl.d/60-regolith-can.conf \
         /usr/share/doc/regolith/copyright /usr/share/doc/regolith/changelog.Debian.gz \
         /usr/share/doc/regolith/README.md /usr/share/doc/regolith/README.deploy.md \
         /usr/share/man/man1/regolith.1.gz; do
  grep -qx "$f" "$work/contents.txt" || fail "package lacks $f"
done
if grep -E '^/usr/local|^/usr/include|\.a$|/cmake/' "$work/contents.txt"; then
  fail "package holds developer files (above)"
fi
echo "contents: $(grep -vc '/$' "$work/contents.txt") entries"

# ---- 3. lintian -----------------------------------------------------------------------------------
lintian --tag-display-limit 0 "$deb" >"$work/lintian.txt" 2>&1 || true
echo "lintian:"
sed 's/^/  /' "$work/lintian.txt"
if grep -q '^E: ' "$work/lintian.txt"; then fail "lintian reports errors"; fi

# ---- 4. extracted install -------------------------------------------------------------------------
root=$work/root
dpkg -x "$deb" "$root"
regolith=$root/usr/bin/regolith
"$regolith" --help >"$work/help.txt" || fail "regolith --help failed"
grep -q 'config' "$work/help.txt" || fail "--help does not list the config command"
"$regolith" --version | grep -qx "regolith $(field Version | sed 's/-[^-]*$//')" || fail "--version mismatch"
# Every shipped deployment must validate on a machine without its devices (config check opens none).
bad=0
for cfg in "$root"/etc/regolith/*.yaml; do
  set +e
  out=$("$regolith" config check "$cfg" 2>&1)
  rc=$?
  set -e
  if [[ $rc -ne 0 ]] || ! grep -q "^# $cfg: OK" <<<"$out"; then
    echo "config check $(basename "$cfg"): exit $rc: $(grep -v ' INFO ' <<<"$out" | head -3)"
    bad=1
  else
    echo "config check $(basename "$cfg"): $(grep "^# $cfg: OK" <<<"$out" | sed 's/.*: OK //')"
  fi
done
((bad == 0)) || fail "a shipped deployment does not pass config check (above)"
set +e
out=$("$regolith" config check "$root/etc/regolith/missing.yaml" 2>&1)
rc=$?
set -e
[[ $rc -eq 2 ]] || fail "missing deployment: exit status $rc, expected 2 ($out)"
grep -q "missing.yaml" <<<"$out" || fail "missing deployment: message does not name the file: $out"
echo "missing deployment: exit 2, '$out'"
echo "package: OK"
