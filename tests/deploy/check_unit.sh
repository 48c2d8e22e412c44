#!/usr/bin/env bash
# deploy.systemd_unit: deploy/systemd/regolith.service passes `systemd-analyze verify` with no
# message at all (verify exits 0 even for unknown keys or unparsable values, so any output fails),
# its `systemd-analyze security` exposure is below 3.0, and the settings the deployment relies on
# are present. The unit's ExecStart (/usr/bin/regolith) is pointed at the built binary in a copy,
# because verify requires the executable to exist.
#   check_unit.sh UNIT_FILE REGOLITH_BINARY
set -euo pipefail
unit=$1
binary=$2
fail() { echo "FAIL: $*" >&2; exit 1; }
command -v systemd-analyze >/dev/null || fail "systemd-analyze not found: install Debian package 'systemd'"
[[ -x $binary ]] || fail "$binary is not an executable"

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
grep -q '^ExecStart=/usr/bin/regolith ' "$unit" || fail "ExecStart must run /usr/bin/regolith"
sed "s|^ExecStart=/usr/bin/regolith |ExecStart=$binary |" "$unit" >"$work/regolith.service"

out=$(systemd-analyze verify "$work/regolith.service" 2>&1) || fail "systemd-analyze verify failed: $out"
[[ -z $out ]] || fail "systemd-analyze verify reported problems:
$out"
echo "systemd-analyze verify: clean"

sec=$(systemd-analyze security --offline=yes "$work/regolith.service" 2>&1) || true
score=$(sed -n 's/.*Overall exposure level for regolith.service: \([0-9.]*\).*/\1/p' <<<"$sec")
[[ -n $score ]] || fail "no exposure score in systemd-analyze security output:
$sec"
echo "systemd-analyze security: exposure $score"
awk -v s="$score" 'BEGIN { exit !(s < 3.0) }' || fail "exposure $score is not below 3.0"

# Settings the deployment depends on (README.deploy.md documents each).
for want in 'Type=notify' 'WatchdogSec=' 'Restart=on-failure' 'RestartPreventExitStatus=2' 'StartLimitBurst=' \
            'LimitRTPRIO=' 'LimitMEMLOCK=infinity' 'User=regolith' 'SupplementaryGroups=video' \
            'NoNewPrivileges=yes' 'ProtectSystem=strict' 'ProtectHome=yes' 'PrivateTmp=yes' \
            'RestrictAddressFamilies=AF_UNIX AF_NETLINK AF_CAN AF_INET AF_INET6' 'DeviceAllow=char-video4linux rw' \
            '#CPUAffinity='; do
  grep -q "^$want" "$unit" || fail "unit lacks '$want'"
done
# Exit status 2 (configuration error) must stop restarts, 3 (device unavailable at start-up) must not.
prevent=$(sed -n 's/^RestartPreventExitStatus=//p' "$unit")
[[ $prevent == 2 ]] || fail "RestartPreventExitStatus must be exactly 2 (exit status 3 is restartable), got '$prevent'"
# RestrictRealtime=yes would forbid the SCHED_FIFO rate groups.
if grep -q '^RestrictRealtime=yes' "$unit"; then fail "RestrictRealtime=yes forbids SCHED_FIFO"; fi
echo "regolith.service: OK"
