# Copyright 2026 formation_control developers
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Compare the tracked benchmarks (bench/suite) of a base commit with the work tree.

The base commit's tree is exported (``git archive``) into a temporary directory and timed with
the work tree's benchmark definitions, ``PYTHONPATH`` pointing at it, then the work tree the
same way, alternately ``--repeat`` times (a load that drifts then weighs on both alike); the
compiled modules of both trees (the RK4 kernel) are built in place first. Prints
each benchmark's median over the repeats of its medians, base and now, their ratio, and flags
a ratio above 1 + threshold as a regression (exit status 1). A benchmark the base cannot run
(a function it does not have yet) is listed as new.

Usage: python tools/bench_compare.py BASE [--threshold 0.2] [--repeat 3] [-- PYTEST_ARGS...]
"""
import argparse
import json
import os
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile

ROOT = Path(__file__).resolve().parents[1]
IMPORTED = 'import formation_control as f; print(f.__file__)'


def timed(tree, out, pytest_args):
    """Run the suite against the package in ``tree``; return {benchmark: median seconds}."""
    env = dict(os.environ, PYTHONPATH=str(tree), ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    where = subprocess.run([sys.executable, '-c', IMPORTED], env=env, cwd=tree, check=True,
                           capture_output=True, text=True).stdout
    if not Path(where.strip()).is_relative_to(tree):
        sys.exit(f'bench-compare: {tree} is not the tree imported ({where.strip()})')
    print(f'# timing {tree}', flush=True)
    subprocess.run([sys.executable, '-m', 'pytest', '-q', '-p', 'no:cacheprovider',
                    str(ROOT / 'bench' / 'suite'), f'--benchmark-json={out}',
                    '--benchmark-columns=median,iqr,rounds', *pytest_args],
                   cwd=tree, env=env, check=False)
    if not out.exists():
        sys.exit(f'bench-compare: no benchmark ran against {tree}')
    return {b['fullname'].split('::', 1)[1]: b['stats']['median']
            for b in json.loads(out.read_text())['benchmarks']}


def export(rev, into):
    """Write the tree of commit ``rev`` into the directory ``into``, its extensions built."""
    archive = subprocess.run(['git', '-C', str(ROOT), 'archive', rev], check=True,
                             capture_output=True).stdout
    subprocess.run(['tar', '-x', '-C', str(into)], input=archive, check=True)
    build(into)


def build(tree):
    """Build the compiled modules of ``tree`` in place (the RK4 kernel; none before it)."""
    subprocess.run([sys.executable, 'setup.py', '-q', 'build_ext', '--inplace'], cwd=tree,
                   check=True, capture_output=True)


def report(base, now, threshold):
    """Print the comparison table; return the names of the regressions."""
    print(f"\n{'benchmark':52s} {'base':>11s} {'now':>11s} {'now/base':>9s}")
    slower = []
    for name in sorted(now.keys() | base.keys()):
        b, n = base.get(name), now.get(name)
        if b is None or n is None:
            print(f"{name:52s} {'-' if b is None else _ms(b):>11s} "
                  f"{'-' if n is None else _ms(n):>11s} {'new' if b is None else 'gone':>9s}")
            continue
        flag = '  REGRESSION' if n / b > 1 + threshold else ''
        print(f'{name:52s} {_ms(b):>11s} {_ms(n):>11s} {n / b:9.2f}{flag}')
        if flag:
            slower.append(name)
    return slower


def _medians(runs):
    """Return each benchmark's median over the runs that have it."""
    names = set().union(*runs)
    return {name: statistics.median(run[name] for run in runs if name in run) for name in names}


def _ms(seconds):
    return f'{1e3 * seconds:.3f} ms'


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('base', help='the commit to compare with (a hash, tag or branch)')
    parser.add_argument('--threshold', type=float, default=0.2,
                        help='a ratio above 1 + threshold is a regression (default 0.2)')
    parser.add_argument('--repeat', type=int, default=3,
                        help='alternate base and now this many times (default 3)')
    parser.add_argument('pytest_args', nargs='*', help='after --: passed to pytest (e.g. -k)')
    args = parser.parse_intermixed_args()      # BASE --repeat 3 -- -k x as well
    with tempfile.TemporaryDirectory(prefix='bench_compare_') as tmp:
        tree = Path(tmp) / 'base'
        tree.mkdir()
        export(args.base, tree)
        build(ROOT)
        runs = {'base': [], 'now': []}
        for i in range(args.repeat):
            for key, where in (('base', tree), ('now', ROOT)):
                runs[key].append(timed(where, Path(tmp) / f'{key}{i}.json', args.pytest_args))
    base, now = (_medians(runs[key]) for key in ('base', 'now'))
    slower = report(base, now, args.threshold)
    if slower:
        sys.exit(f'\nbench-compare: {len(slower)} regression(s) over {args.threshold:.0%} '
                 f'against {args.base}: {", ".join(slower)}')
    print(f'\nbench-compare: no regression over {args.threshold:.0%} against {args.base}')


if __name__ == '__main__':
    main()
