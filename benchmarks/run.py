# Copyright 2026 observer_ros contributors
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
Run the benchmark suite and write ``BENCHMARKS.md`` with its figures.

``python -m benchmarks.run [--smoke] [--only N [N ...]] [--output DIR]`` (or
``./scripts/benchmark.sh``). Each section measures the package against its baseline in the
same run and reports ratios; ``--smoke`` runs every section on tiny sizes in seconds (CI).
``--only`` replaces those sections in an existing report and keeps the others.
"""

import argparse
import datetime
import importlib
import os
from pathlib import Path
import platform
import re
import sys
import time
import warnings

from benchmarks.common import Figures, REPOSITORY, RUN_LENGTH

#: A section's goal (met, not met, only measured) in the progress line and in the table.
GOAL_WORDS = {True: 'met', False: 'NOT met', None: 'measured'}
TABLE_WORDS = {True: 'met', False: '**not met**', None: 'measured'}

#: Section number -> module.
SECTIONS = {1: 'design', 2: 'update', 3: 'throughput', 4: 'ros_latency', 5: 'closed_loop',
            6: 'noise', 7: 'scale', 8: 'decoding', 9: 'sources', 10: 'nonlinear'}


def environment() -> str:
    """One line about the machine and the library versions."""
    import control
    import numpy
    import scipy
    versions = f'numpy {numpy.__version__}, scipy {scipy.__version__}, ' \
               f'python-control {control.__version__}'
    return (f'{platform.machine()}, {os.cpu_count()} CPUs, Python '
            f'{platform.python_version()}, {versions}, RMW '
            f'{os.environ.get("RMW_IMPLEMENTATION", "default (Fast DDS)")}')


def previous_sections(text: str) -> tuple:
    """Summary rows and section bodies of an existing report, by section number."""
    rows = {int(m.group(1)): m.group(0)
            for m in re.finditer(r'^\| (\d+)\. .*\|$', text, flags=re.MULTILINE)}
    bodies = {}
    parts = re.split(r'^(?=## \d+\. )', text, flags=re.MULTILINE)
    for part in parts[1:]:
        bodies[int(part[3:].split('.')[0])] = part.rstrip() + '\n'
    return rows, bodies


def main(args=None) -> int:
    """Run the selected sections and write the report."""
    parser = argparse.ArgumentParser(prog='benchmarks.run', description=__doc__.splitlines()[1])
    parser.add_argument('--smoke', action='store_true', help='tiny sizes, seconds (CI)')
    parser.add_argument('--only', type=int, nargs='+', choices=sorted(SECTIONS),
                        metavar='N', help='run only these sections')
    parser.add_argument('--output', default=str(REPOSITORY), metavar='DIR',
                        help='where BENCHMARKS.md and benchmarks/figures/ go (default: the '
                        'repository)')
    parser.add_argument('--runs', type=int, metavar='N',
                        help='section 5: runs per rate and set-up, the worst shown (default 5; '
                        '1 with --smoke)')
    parser.add_argument('--seconds', type=float, metavar='S',
                        help='section 5: seconds per real-time run (default 2)')
    parser.add_argument('--rates', type=float, nargs='+', metavar='HZ',
                        help='section 5: plant rates (default 100 250 500 1000 2000)')
    parser.add_argument('--rounds', type=int, metavar='N',
                        help='section 4: round trips per node and executor (default 3000)')
    options = parser.parse_args(args)
    lengths = ('runs', 'seconds', 'rates', 'rounds')
    RUN_LENGTH.update({key: getattr(options, key) for key in lengths
                       if getattr(options, key) is not None})
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    os.environ.setdefault('MPLBACKEND', 'Agg')
    warnings.simplefilter('ignore')
    root = Path(options.output).resolve()
    figures = Figures(root, root / 'benchmarks' / 'figures')
    sections = []
    for number in options.only or sorted(SECTIONS):
        module = importlib.import_module(f'benchmarks.{SECTIONS[number]}')
        started = time.perf_counter()
        print(f'[{number}] {SECTIONS[number]} ...', flush=True)
        section = module.run(options.smoke, figures)
        print(f'[{number}] done in {time.perf_counter() - started:.1f} s: goal '
              f'{GOAL_WORDS[section.met]}', flush=True)
        sections.append(section)
    rows = {s.number: f'| {s.number}. {s.title} | {s.goal} | {TABLE_WORDS[s.met]} |'
            for s in sections}
    bodies = {s.number: s.markdown() for s in sections}
    report = root / 'BENCHMARKS.md'
    notes = []
    if options.only and report.exists():
        # Keep the sections not run now from the existing report.
        old_rows, old_bodies = previous_sections(report.read_text(encoding='utf-8'))
        kept = sorted(set(old_bodies) - set(bodies))
        rows = {**{k: old_rows[k] for k in kept if k in old_rows}, **rows}
        bodies = {**{k: old_bodies[k] for k in kept}, **bodies}
        if kept:
            notes = [f'Kept from an earlier run: sections {", ".join(map(str, kept))}.']
    text = ['# Benchmarks', '',
            f'Written by `{" ".join(["python -m benchmarks.run", *(args or sys.argv[1:])])}` '
            f'on {datetime.date.today().isoformat()}{" (smoke run)" if options.smoke else ""}'
            f'; {environment()}. Absolute times vary between machines; each comparison is '
            'measured in the same run against its baseline.', *notes, '',
            '| section | goal | result |', '|---|---|---|', *(rows[k] for k in sorted(rows)),
            '', *(bodies[k] for k in sorted(bodies))]
    report.write_text('\n'.join(text), encoding='utf-8')
    print(f'wrote {root / "BENCHMARKS.md"}')
    return 0


if __name__ == '__main__':
    sys.exit(main())
