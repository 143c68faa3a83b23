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

"""SciPy's place_poles and linear_sum_assignment, without scipy.signal and scipy.optimize."""

import re
import subprocess
import sys
import warnings

import numpy as np
import pytest
import scipy.optimize
import scipy.signal

from observer_ros.core import scipy_parts


def _systems():
    """Yield (A, B, poles): one and several inputs, real and complex poles, 2 to 12 states."""
    rng = np.random.default_rng(20261205)
    for n in (2, 3, 4, 6, 9):
        for m in sorted({1, 2, n // 2}):
            for _ in range(3):
                a, b = rng.normal(size=(n, n)), rng.normal(size=(n, m))
                pairs = rng.integers(0, n // 2 + 1)
                real = -rng.uniform(0.5, 5.0, size=n - 2 * pairs)
                complex_ = (-rng.uniform(0.5, 5.0, size=pairs)
                            + 1j * rng.uniform(0.1, 3.0, size=pairs))
                yield a, b, np.concatenate([real, complex_, complex_.conj()])


@pytest.mark.parametrize('maxiter', [3, 50])
def test_the_gains_are_scipy_signals_bit_for_bit(maxiter):
    ours = scipy_parts.place_poles()
    assert ours is not scipy.signal.place_poles  # compiled from source, not imported
    count = 0
    for a, b, poles in _systems():
        with warnings.catch_warnings(record=True) as theirs_warned:
            warnings.simplefilter('always')
            try:
                theirs = scipy.signal.place_poles(a, b, poles, method='YT', maxiter=maxiter)
            except ValueError as error:
                with pytest.raises(ValueError, match=re.escape(str(error))):
                    ours(a, b, poles, method='YT', maxiter=maxiter)
                continue
        with warnings.catch_warnings(record=True) as ours_warned:
            warnings.simplefilter('always')
            result = ours(a, b, poles, method='YT', maxiter=maxiter)
        for field in ('gain_matrix', 'computed_poles', 'requested_poles', 'X'):
            assert np.array_equal(getattr(result, field), getattr(theirs, field)), field
        assert (result.rtol, result.nb_iter) == (theirs.rtol, theirs.nb_iter)
        assert [str(w.message) for w in ours_warned] == [str(w.message) for w in theirs_warned]
        count += 1
    assert count >= 30


def test_its_errors_are_scipys():
    ours = scipy_parts.place_poles()
    for poles in ([-1.0, -1.0, -1.0], [-1.0 + 1j, -2.0, -3.0]):
        with pytest.raises(ValueError) as theirs:
            scipy.signal.place_poles(np.eye(3), np.ones((3, 1)), poles)
        with pytest.raises(ValueError, match=re.escape(str(theirs.value))):
            ours(np.eye(3), np.ones((3, 1)), poles)


def test_linear_sum_assignment_is_scipy_optimizes_own_function():
    assert scipy_parts.linear_sum_assignment() is scipy.optimize.linear_sum_assignment


def test_another_scipy_falls_back_to_the_import(monkeypatch):
    # A definition that names something _ltisys's imports do not give: not compiled.
    monkeypatch.setattr(scipy_parts, 'DEFINITIONS', (*scipy_parts.DEFINITIONS, 'no_such'))
    assert scipy_parts.from_source() is None
    monkeypatch.setattr(scipy_parts, '_LOADED', {})
    assert scipy_parts.place_poles() is scipy.signal.place_poles
    monkeypatch.setattr(scipy_parts, '_globals', lambda: {'np': np})  # s_qr missing
    monkeypatch.setattr(scipy_parts, 'DEFINITIONS', scipy_parts.DEFINITIONS[:-1])
    assert scipy_parts.from_source() is None


def test_a_design_imports_neither_scipy_signal_nor_scipy_optimize():
    code = ('import sys\n'
            'from observer_ros.core.placement import place\n'
            'from observer_ros.core.placement_methods import preload_methods\n'
            'preload_methods()\n'
            'place([[0.0, 1.0], [0.0, 0.0]], [[0.0], [1.0]], [-1.0 + 1j, -1.0 - 1j])\n'
            "print(sorted(m for m in ('scipy.signal', 'scipy.optimize', 'scipy.stats')"
            ' if m in sys.modules))\n')
    result = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                            check=True, timeout=60)
    assert result.stdout.strip() == '[]', result.stdout
