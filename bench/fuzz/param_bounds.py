#!/usr/bin/env python3
"""Every numeric deployment parameter at its bounds, through `regolith config check`.

For each numeric parameter `regolith config check DEPLOYMENT` lists (with its range, e.g.
"# default, [64, 4096]" or "# > 0"), the deployment is checked again with that one parameter at
each end of its range (an unbounded side: 1e9 or -1e9), devices not opened, as a user's typo
would set it. Each run must either pass (exit 0) or name the parameter (exit 2); anything else
(a crash, an uncaught exception, exit 1), more than --max-cpu-s seconds of CPU or more than
--max-rss-mb of memory is reported. Exit status 1 when something was.

  bench/fuzz/param_bounds.py [--regolith PATH] DEPLOYMENT.yaml...

Needs python3-yaml (deploy/setup.sh, profile test). Not part of CI (~1 s per case, ~700 cases
for config/mock_rover.yaml); it complements the fuzz target deployment_check, which mutates
bytes and rarely lands on a number's extreme.
"""
import argparse
import copy
import os
import re
import shutil
import subprocess
import sys
import tempfile

import yaml

ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
ap.add_argument('deployments', nargs='+')
ap.add_argument('--regolith', default=os.path.join(os.path.dirname(__file__), '../../build/release/tools/regolith'))
ap.add_argument('--max-cpu-s', type=float, default=4.0)
ap.add_argument('--max-rss-mb', type=float, default=1500.0)
args = ap.parse_args()

LINE = re.compile(r'^([A-Za-z0-9_.\[\]]+): (-?[0-9.eE+-]+)(?: \[[^\]]*\])?(?:  # (.*))?$')
RANGE = re.compile(r'([\[(])([-0-9.e+]+), ([-0-9.e+]+)([\])])')


def extremes(value, comment):
    """The values at each end of the parameter's range (inside an open end by one step)."""
    whole = re.fullmatch(r'-?[0-9]+', value) is not None
    step = 1 if whole else 1e-9
    m = RANGE.search(comment)
    if m:
        lo, hi = float(m.group(2)), float(m.group(3))
        vals = [lo if m.group(1) == '[' else lo + step, hi if m.group(4) == ']' else hi - step]
    elif '>= ' in comment:
        vals = [float(re.search(r'>= ([-0-9.e+]+)', comment).group(1)), 1e9]
    elif '> ' in comment:
        vals = [float(re.search(r'> ([-0-9.e+]+)', comment).group(1)) + step, 1e9]
    else:
        vals = [1e9, -1e9]
    if whole:
        vals = [int(max(min(v, 2**31 - 1), -2**31)) for v in vals]
    return vals


def set_path(doc, key, value):
    """Set `a.b[2].c` in the parsed YAML, creating mappings for defaults; False if not a path."""
    parts = re.findall(r'[^.\[\]]+|\[\d+\]', key)
    cur = doc
    for i, p in enumerate(parts):
        last = i == len(parts) - 1
        if p.startswith('['):
            idx = int(p[1:-1])
            if not isinstance(cur, list) or idx >= len(cur):
                return False
            if last:
                cur[idx] = value
                return True
            cur = cur[idx]
            continue
        if not isinstance(cur, dict):
            return False
        if last:
            cur[p] = value
            return True
        if cur.get(p) is None:
            cur[p] = {}
        cur = cur[p]
    return False


def check(path):
    r = subprocess.run(['/usr/bin/time', '-f', 'RSS %M CPU %U %S', args.regolith, 'config', 'check', path],
                       capture_output=True, text=True)
    m = re.search(r'RSS (\d+) CPU ([0-9.]+) ([0-9.]+)', r.stderr)
    rss_mb = int(m.group(1)) / 1024 if m else -1
    cpu = float(m.group(2)) + float(m.group(3)) if m else -1
    last = [l for l in r.stderr.splitlines() if not l.startswith('RSS ') and 'exited with' not in l][-1:]
    return r.returncode, cpu, rss_mb, (last[0] if last else '')


bad = 0
for dep in args.deployments:
    # In a scratch directory that links every file beside the original, so that its relative paths
    # (images, models, token files) still resolve and the source tree is never written (a file left
    # in config/ is globbed by the build's packaging and allocation-probe lists).
    here = os.path.dirname(os.path.abspath(dep))
    scratch = tempfile.mkdtemp(prefix='param_bounds_')
    for entry in os.listdir(here):
        os.symlink(os.path.join(here, entry), os.path.join(scratch, entry))
    path = os.path.join(scratch, 'probe_' + os.path.basename(dep))
    try:
        listed = subprocess.run([args.regolith, 'config', 'check', dep], capture_output=True, text=True)
        if listed.returncode != 0:
            sys.exit(f'{dep}: does not pass config check itself: {listed.stderr.strip()}')
        base = yaml.safe_load(open(dep))
        cases = []
        for line in listed.stdout.splitlines():
            m = LINE.match(line)
            if m:
                cases += [(m.group(1), v) for v in extremes(m.group(2), m.group(3) or '')]
        counts = {0: 0, 2: 0}
        for key, v in cases:
            doc = copy.deepcopy(base)
            if not set_path(doc, key, v):
                continue
            with open(path, 'w') as f:
                yaml.safe_dump(doc, f)
            rc, cpu, rss, last = check(path)
            if rc in (126, 127):  # e.g. the binary being relinked by a build meanwhile
                sys.exit(f'{args.regolith}: could not be run ({last}); the probe stopped at {key}={v}')
            if rc in counts:
                counts[rc] += 1
            if rc not in (0, 2) or cpu > args.max_cpu_s or rss > args.max_rss_mb:
                bad += 1
                print(f'{dep}: {key}={v}: exit {rc}, {cpu:.1f} s CPU, {rss:.0f} MB: {last}', flush=True)
        print(f'{dep}: {len(cases)} cases: {counts[0]} pass, {counts[2]} refused with a located error, '
              f'{len(cases) - counts[0] - counts[2]} other', flush=True)
    finally:
        shutil.rmtree(scratch)
sys.exit(1 if bad else 0)
