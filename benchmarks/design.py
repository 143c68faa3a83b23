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
1. Observer design against ``control.place`` / ``control.acker`` on the same problems.

Every returned gain, whichever method produced it, is judged by the same yardstick: the
closed-loop eigenvalues computed in double precision, matched one to one with the requested
poles, each isolated pole to the relative tolerance, and each cluster of (nearly) repeated
poles through the coefficients of its own polynomial (the eigenvalues of a Jordan block
scatter by eps^(1/k) even for an exact gain; their symmetric functions do not). A gain that
misses is *silently wrong*; an exception is an honest refusal.
"""

from collections import defaultdict
import time
import warnings

import control
import numpy as np

from benchmarks.common import pyplot, random_poles, random_stable_system, Section
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.placement import DEFAULT_RTOL, place_observer
from observer_ros.core.placement_checks import placement_residual

TOLERANCE = DEFAULT_RTOL


def pole_error(matrix: np.ndarray, poles: np.ndarray) -> float:
    """Relative error of ``eig(matrix)`` against ``poles`` (clusters by coefficients)."""
    return placement_residual(matrix, poles)[0]


def problems(rng, sizes, outputs, trials):
    """Yield ``(kind, A, C, poles)``: distinct, repeated and nearly repeated poles."""
    for n in sizes:
        for p in outputs:
            if p > n:
                continue
            for _ in range(trials if n <= 16 else max(1, trials // 2)):
                a, _, c = random_stable_system(rng, n, 1, p)
                yield 'distinct', a, c, random_poles(rng, n)
                if n <= 12:
                    # One pole of multiplicity min(n, 3 p) (at most p Jordan blocks per
                    # pole are needed), the rest distinct.
                    k = min(n, 3 * p)
                    rest = random_poles(rng, n - k, 4.0, 8.0) if n > k else np.zeros(0)
                    repeated = np.concatenate([np.full(k, -2.0 + 0j), rest])
                    yield 'repeated', a, c, repeated
                    nearly = repeated.copy()
                    nearly[:k] = -2.0 * (1.0 + 1e-9 * np.arange(k))
                    yield 'nearly repeated', a, c, nearly


def attempt(function, a, c, poles):
    """Return ``(outcome, error, seconds)``: 'ok', 'refused' or 'wrong'."""
    started = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter('ignore')
            gain = function(a, c, poles)
    except (DesignError, ConfigError, ValueError, ArithmeticError, np.linalg.LinAlgError,
            control.ControlArgument, control.ControlDimension) as e:
        return 'refused', type(e).__name__, time.perf_counter() - started
    except Exception as e:  # noqa: B902 - SLICOT and python-control raise their own types
        return 'refused', type(e).__name__, time.perf_counter() - started
    seconds = time.perf_counter() - started
    gain = np.asarray(gain)
    if np.iscomplexobj(gain) or not np.isfinite(gain).all():
        return 'wrong', float('inf'), seconds
    error = pole_error(a - gain.reshape(a.shape[0], -1) @ c, poles)
    return ('ok' if error <= TOLERANCE else 'wrong'), error, seconds


def ours(a, c, poles):
    """Design with the package (verified)."""
    return place_observer(a, c, poles).gain


def control_place(a, c, poles):
    """``control.place`` by duality."""
    return np.asarray(control.place(a.T, c.T, poles)).T


def control_acker(a, c, poles):
    """``control.acker`` by duality (single output only)."""
    if c.shape[0] != 1:
        raise control.ControlDimension('acker needs one output')
    return np.asarray(control.acker(a.T, c.T, poles)).T


METHODS = {'observer_ros': ours, 'control.place': control_place,
           'control.acker': control_acker}


def run(smoke: bool, figures) -> Section:
    """Measure and return the section."""
    section = Section(1, 'Design: success, accuracy and time against python-control',
                      'never a silently wrong gain (every failure is an error), and success '
                      'wherever a correct gain exists in double precision')
    sizes = [2, 4, 8] if smoke else [2, 4, 8, 16, 32, 64]
    outputs = [1, 2] if smoke else [1, 2, 4, 8]
    trials = 1 if smoke else 4
    rng = np.random.default_rng(2026)
    tally = defaultdict(lambda: defaultdict(int))
    worst = defaultdict(float)
    times = defaultdict(list)
    by_size = defaultdict(lambda: defaultdict(list))
    exists = ours_missed = 0
    for kind, a, c, poles in problems(rng, sizes, outputs, trials):
        outcomes = {}
        for name, function in METHODS.items():
            if name == 'control.acker' and c.shape[0] != 1:
                continue
            outcome, error, seconds = attempt(function, a, c, poles)
            outcomes[name] = outcome
            tally[(name, kind)][outcome] += 1
            if outcome == 'ok':
                worst[(name, kind)] = max(worst[(name, kind)], error)
                times[(name, kind)].append(seconds)
                by_size[name][a.shape[0]].append(error)
            elif outcome == 'wrong':
                by_size[name][a.shape[0]].append(min(error, 1e3))
        if 'ok' in outcomes.values():
            exists += 1
            ours_missed += outcomes['observer_ros'] != 'ok'
    rows = []
    for (name, kind), counts in sorted(tally.items(), key=lambda item: (item[0][1], item[0][0])):
        total = sum(counts.values())
        median = np.median(times[(name, kind)]) * 1e3 if times[(name, kind)] else float('nan')
        rows.append([kind, name, total, counts['ok'], counts['refused'], counts['wrong'],
                     f'{worst[(name, kind)]:.1e}' if counts['ok'] else '-',
                     f'{median:.2f}'])
    section.add(f'Seeded random stable systems (A random, C random), n in {sizes}, p in '
                f'{outputs}, {trials} per (n, p), poles random in the left half plane; for '
                'n <= 12 also one pole of multiplicity min(n, 3p) (repeated) and the same '
                'cluster spread by 1e-9 relative (nearly repeated). Tolerance: relative error '
                f'{TOLERANCE:g} on the eigenvalues computed in double precision (clusters '
                'through their polynomial), the same yardstick for every method.', '')
    section.table(['poles', 'method', 'problems', 'correct', 'refused (error)',
                   'silently wrong', 'worst error when correct', 'median ms'], rows)
    wrong_ours = sum(tally[(name, kind)]['wrong'] for name, kind in tally
                     if name == 'observer_ros')
    place_ms = [t for (name, _), values in times.items() if name == 'control.place'
                for t in values]
    our_ms = [t for (name, _), values in times.items() if name == 'observer_ros'
              for t in values]
    section.add(f'A correct gain was found by some method for {exists} problems; '
                f'observer_ros returned one for {exists - ours_missed} of them and a silently '
                f'wrong gain for {wrong_ours}. Median design time: observer_ros '
                f'{np.median(our_ms) * 1e3:.2f} ms, control.place '
                f'{np.median(place_ms) * 1e3:.2f} ms (observer_ros verifies every gain and '
                'falls back to other algorithms when one misses).', '')
    section.met = wrong_ours == 0 and ours_missed == 0
    plt = pyplot()
    pyplot_figure, axis = plt.subplots(figsize=(7, 4))
    for name, marker in zip(METHODS, 'os^'):
        sizes_seen = sorted(by_size[name])
        if sizes_seen:
            axis.semilogy(sizes_seen, [max(max(by_size[name][n]), 1e-17) for n in sizes_seen],
                          marker=marker, label=name)
    axis.axhline(TOLERANCE, color='k', linestyle='--', label='tolerance')
    axis.set_xscale('log', base=2)
    axis.set_xlabel('n (states)')
    axis.set_ylabel('worst relative pole error\n(returned gains)')
    axis.legend()
    section.figures.append(figures.save(pyplot_figure, 'design_accuracy'))
    return section
