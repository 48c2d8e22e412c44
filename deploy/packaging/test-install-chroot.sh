#!/usr/bin/env bash
# Install the Debian package into a fresh, minimal Debian 12 root exactly as a user would
# (`apt install ./regolith_*.deb`, dependencies downloaded from Debian), run the installed tool,
# check the system user, then purge the package and check that nothing is left behind.
# Needs root, network access to the Debian mirror and mmdebstrap; takes a few minutes (too slow
# for the `deploy` CTest label, which checks the package with dpkg-deb, lintian and dpkg -x).
#   sudo bash deploy/packaging/test-install-chroot.sh build/release/packages/regolith_0.1.0-1_amd64.deb
set -euo pipefail
deb=$(realpath "$1")
[[ -f $deb ]] || { echo "no such package: $1" >&2; exit 2; }
root=$(mktemp -d /tmp/regolith-chroot.XXXXXX)
trap 'rm -rf "$root"' EXIT
mirrors=()
for f in /etc/apt/sources.list.d/*.sources /etc/apt/sources.list; do
  [[ -s $f ]] && grep -q "^[^#]*debian" "$f" && mirrors+=("$f")
done
t0=$SECONDS
cp "$deb" /tmp/regolith-under-test.deb
# shellcheck disable=SC2016  # the hooks are expanded by mmdebstrap's shell, with $1 = the root
mmdebstrap --quiet --variant=apt --skip=cleanup/apt/lists \
  --customize-hook='cp /tmp/regolith-under-test.deb "$1/tmp/"' \
  --customize-hook='chroot "$1" env DEBIAN_FRONTEND=noninteractive apt-get install -y -q --no-install-recommends /tmp/regolith-under-test.deb' \
  --customize-hook='chroot "$1" regolith --version' \
  --customize-hook='chroot "$1" regolith config check /etc/regolith/mock_rover.yaml | head -1' \
  --customize-hook='chroot "$1" regolith config check /etc/regolith/smart_rover.yaml | head -1' \
  --customize-hook='chroot "$1" getent passwd regolith' \
  --customize-hook='chroot "$1" id regolith | grep -q "(video)"' \
  --customize-hook='test "$(chroot "$1" stat -c %U /var/lib/regolith)" = regolith' \
  --customize-hook='du -sk "$1/usr/bin/regolith"' \
  --customize-hook='chroot "$1" env DEBIAN_FRONTEND=noninteractive apt-get purge -y -q regolith' \
  --customize-hook='! chroot "$1" getent passwd regolith' \
  --customize-hook='! chroot "$1" getent group regolith' \
  --customize-hook='test ! -e "$1/etc/regolith" && test ! -e "$1/var/lib/regolith" && test ! -e "$1/usr/bin/regolith"' \
  --customize-hook='! chroot "$1" dpkg -l regolith 2>/dev/null | grep -q "^[a-z][a-z] "' \
  bookworm "$root" "${mirrors[@]}"
rm -f /tmp/regolith-under-test.deb
echo "chroot install / run / purge: OK in $((SECONDS - t0)) s"
