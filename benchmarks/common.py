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

"""What every benchmark section shares: results, tables, figures, timing, random systems."""

from dataclasses import dataclass, field
import os
from pathlib import Path
import time
from typing import Callable, Optional, Sequence

import numpy as np

REPOSITORY = Path(__file__).resolve().parents[1]
CONFIG_DIR = REPOSITORY / 'config'

#: Lengths of the timed real-time runs, set by ``benchmarks.run`` (``--runs``,
#: ``--seconds``, ``--rates``); a section takes its own defaults for what is not given.
RUN_LENGTH: dict = {}


@dataclass
class Section:
    """One benchmark's outcome: markdown lines, figures, and whether its goal was met."""

    number: int
    title: str
    goal: str
    met: Optional[bool] = None
    lines: list = field(default_factory=list)
    figures: list = field(default_factory=list)

    def add(self, *lines: str) -> None:
        """Append markdown lines."""
        self.lines.extend(lines)

    def table(self, header: Sequence[str], rows: Sequence[Sequence]) -> None:
        """Append a markdown table."""
        self.lines.append('| ' + ' | '.join(header) + ' |')
        self.lines.append('|' + '---|' * len(header))
        for row in rows:
            self.lines.append('| ' + ' | '.join(str(cell) for cell in row) + ' |')
        self.lines.append('')

    def markdown(self) -> str:
        """Render the section in Markdown, figures relative to the report."""
        verdict = {True: 'met', False: 'NOT met', None: 'measured'}[self.met]
        text = [f'## {self.number}. {self.title}', '', f'Goal: {self.goal} **({verdict})**',
                '', *self.lines]
        text += [f'![{self.title}]({figure})' for figure in self.figures]
        return '\n'.join(text).rstrip() + '\n'


class Figures:
    """Save matplotlib figures under ``directory``; hand back paths relative to ``root``."""

    def __init__(self, root: Path, directory: Path) -> None:
        self.root = root
        self.directory = directory
        directory.mkdir(parents=True, exist_ok=True)

    def save(self, figure, name: str) -> str:
        """Write ``name``.png and close the figure."""
        import matplotlib.pyplot as plt
        path = self.directory / f'{name}.png'
        figure.tight_layout()
        figure.savefig(path, dpi=90)
        plt.close(figure)
        return path.relative_to(self.root).as_posix()


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend."""
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def stolen_seconds() -> Optional[float]:
    """
    Return the CPU time the hypervisor has taken from this machine so far (all CPUs), or None.

    Linux's ``steal`` column of ``/proc/stat``: time a virtual CPU was ready to run and the
    host ran something else. The difference over a run says how much of it the machine
    did not have, which no code in the run can win back.
    """
    try:
        with open('/proc/stat') as stat:
            fields = stat.readline().split()
        return int(fields[8]) / os.sysconf('SC_CLK_TCK')
    except (OSError, IndexError, ValueError):
        return None


def per_call(function: Callable[[], object], repeat: int, rounds: int = 3) -> float:
    """Best-of-``rounds`` seconds per call of ``function`` over ``repeat`` calls."""
    best = float('inf')
    for _ in range(rounds):
        started = time.perf_counter()
        for _ in range(repeat):
            function()
        best = min(best, (time.perf_counter() - started) / repeat)
    return best


def timed(function: Callable[[], object]):
    """Return ``(result, seconds)`` of one call."""
    started = time.perf_counter()
    result = function()
    return result, time.perf_counter() - started


def random_stable_system(rng: np.random.Generator, n: int, m: int, p: int):
    """Random ``(A, B, C)`` with eigenvalues of ``A`` in the open left half plane."""
    a = rng.standard_normal((n, n)) / np.sqrt(n)
    shift = max(0.0, np.linalg.eigvals(a).real.max()) + 0.5
    return a - shift * np.eye(n), rng.standard_normal((n, m)), rng.standard_normal((p, n))


def random_poles(rng: np.random.Generator, count: int, low: float = 1.0,
                 high: float = 6.0) -> np.ndarray:
    """``count`` distinct stable poles, complex ones in conjugate pairs."""
    poles = []
    while len(poles) < count:
        if count - len(poles) >= 2 and rng.random() < 0.5:
            real, imag = -rng.uniform(low, high), rng.uniform(0.2, high / 2)
            poles += [complex(real, imag), complex(real, -imag)]
        else:
            poles.append(complex(-rng.uniform(low, high), 0.0))
    return np.array(poles)
