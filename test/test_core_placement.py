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
Invariants of the verified pole placement on seeded random systems.

The checks here recompute the closed-loop eigenvalues from the returned gain and compare
them with the request themselves (distinct poles one by one after optimal matching,
repeated poles through the mean and spread of their cluster), so they do not trust the
``achieved_poles`` or ``residual`` that ``place`` reports.
"""

import dataclasses

from hypothesis import given, HealthCheck, settings
from hypothesis import strategies as st
import numpy as np
import pytest

from conftest import match
from observer_ros.core import placement
from observer_ros.core.analysis import require_observable
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.poles import clean_poles, parse_pole, parse_poles, to_discrete
from observer_ros.core.ranks import (
    controllability, observability, pbh_lost_modes, require_controllable)

SINGLE_INPUT_METHODS = ('auto', 'place', 'varga', 'acker', 'direct', 'canonical')
MULTI_INPUT_METHODS = ('auto', 'place', 'varga')


def random_system(seed, n_states, n_inputs, scale=1.0):
    """Return a seeded random ``(A, B)``."""
    rng = np.random.default_rng(seed)
    return (scale * rng.standard_normal((n_states, n_states)),
            rng.standard_normal((n_states, n_inputs)))


def random_distinct_poles(seed, count, min_gap=0.3):
    """Return ``count`` stable poles (some in conjugate pairs), at least ``min_gap`` apart."""
    rng = np.random.default_rng(seed + 1000)
    while True:
        n_pairs = int(rng.integers(0, count // 2 + 1))
        poles = []
        for _ in range(n_pairs):
            pole = complex(-rng.uniform(0.5, 6.0), rng.uniform(0.5, 4.0))
            poles += [pole, pole.conjugate()]
        poles += [complex(-rng.uniform(0.5, 8.0)) for _ in range(count - 2 * n_pairs)]
        poles = np.array(poles)
        gaps = np.abs(poles[:, None] - poles[None, :]) + np.eye(count) * 1e9
        if gaps.min() >= min_gap:
            return poles


def assert_eigenvalues(matrix, wanted, rtol=1e-6):
    """
    Assert ``eig(matrix)`` equals ``wanted`` (a multiset), cluster-aware.

    A pole repeated ``k`` times: the mean of its matched eigenvalues is within ``rtol`` and
    each of them within ``4 rtol^(1/k)`` (an exact ``k``-fold eigenvalue is only that
    accurate). A single pole: within ``rtol``, relative to ``max(1, |pole|)``.
    """
    wanted = clean_poles(np.asarray(wanted, dtype=complex))
    eigenvalues = np.linalg.eigvals(matrix)
    assert np.all(np.isfinite(eigenvalues))
    got = match(eigenvalues, wanted)
    seen = set()
    for index, pole in enumerate(wanted):
        if index in seen:
            continue
        group = [j for j in range(wanted.size) if wanted[j] == pole]
        seen.update(group)
        scale = max(1.0, abs(pole))
        members = got[group]
        assert abs(members.mean() - pole) <= rtol * scale, (pole, members)
        spread = 4.0 * rtol ** (1.0 / len(group)) * scale
        assert np.abs(members - pole).max() <= spread, (pole, members)


# --------------------------------------------------------------------------------------
# Distinct poles on random systems.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize('seed', range(4))
@pytest.mark.parametrize('n_states', [2, 3, 4, 6])
@pytest.mark.parametrize('method', SINGLE_INPUT_METHODS)
def test_single_input_distinct_poles(method, n_states, seed):
    a, b = random_system(seed, n_states, 1)
    poles = random_distinct_poles(seed, n_states)
    result = placement.place(a, b, poles, method=method)
    assert result.gain.shape == (1, n_states)
    assert result.gain.dtype == float
    assert_eigenvalues(a - b @ result.gain, poles)
    if method != 'auto':
        assert result.method == method
    assert result.residual <= placement.DEFAULT_RTOL


@pytest.mark.parametrize('seed', range(3))
@pytest.mark.parametrize('n_states, n_inputs', [(3, 2), (4, 2), (5, 3), (6, 2), (4, 4)])
@pytest.mark.parametrize('method', MULTI_INPUT_METHODS)
def test_multi_input_distinct_poles(method, n_states, n_inputs, seed):
    a, b = random_system(seed, n_states, n_inputs)
    poles = random_distinct_poles(seed, n_states)
    result = placement.place(a, b, poles, method=method)
    assert result.gain.shape == (n_inputs, n_states)
    assert_eigenvalues(a - b @ result.gain, poles)


@pytest.mark.parametrize('seed', range(3))
@pytest.mark.parametrize('n_states, n_outputs', [(3, 1), (4, 2), (5, 2), (6, 3)])
def test_observer_duality(n_states, n_outputs, seed):
    rng = np.random.default_rng(seed)
    a = rng.standard_normal((n_states, n_states))
    c = rng.standard_normal((n_outputs, n_states))
    poles = random_distinct_poles(seed, n_states)
    result = placement.place_observer(a, c, poles)
    assert result.gain.shape == (n_states, n_outputs)
    assert_eigenvalues(a - result.gain @ c, poles)


def test_discrete_poles_placed_in_z_plane():
    a, b = random_system(3, 4, 1)
    poles = to_discrete([-1, -2, -3 + 1j, -3 - 1j], 0.1)
    result = placement.place(a, b, poles)
    assert_eigenvalues(a - b @ result.gain, poles)
    assert np.all(np.abs(np.linalg.eigvals(a - b @ result.gain)) < 1.0)


def test_result_is_sorted_and_frozen():
    a, b = random_system(0, 4, 2)
    poles = np.array([-4, -1 + 2j, -2, -1 - 2j])
    result = placement.place(a, b, poles)
    np.testing.assert_array_equal(result.requested_poles, placement.sort_poles(poles))
    assert list(result.requested_poles.real) == sorted(result.requested_poles.real)
    np.testing.assert_allclose(result.achieved_poles, result.requested_poles, rtol=1e-6)
    with pytest.raises(dataclasses.FrozenInstanceError):
        result.gain = np.zeros((2, 4))


# --------------------------------------------------------------------------------------
# Repeated poles.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize('seed', range(3))
@pytest.mark.parametrize('poles', [[-2, -2], [-2, -2, -2], [-1, -1, -3, -3],
                                   [-1.5, -1.5, -1.5, -4], [-1 + 1j, -1 - 1j, -1 + 1j, -1 - 1j]])
def test_single_input_repeated_poles_use_varga(poles, seed):
    a, b = random_system(seed, len(poles), 1)
    result = placement.place(a, b, poles)
    assert result.method == 'varga'
    closed = a - b @ result.gain
    # Characteristic polynomial coefficients, scaled by the pole magnitude.
    scale = float(max(1.0, max(abs(p) for p in poles)))
    powers = scale ** -np.arange(len(poles) + 1)
    difference = (np.poly(np.linalg.eigvals(closed)) - np.real(np.poly(poles))) * powers
    assert np.abs(difference).max() <= 1e-8
    assert_eigenvalues(closed, poles)


@pytest.mark.parametrize('seed', range(3))
def test_multi_input_multiplicity_above_inputs(seed):
    # Multiplicity 3 with 2 inputs: 'auto' must go to Varga's method.
    a, b = random_system(seed, 4, 2)
    poles = [-2, -2, -2, -5]
    result = placement.place(a, b, poles)
    assert result.method == 'varga'
    assert_eigenvalues(a - b @ result.gain, poles)
    with pytest.raises(DesignError, match='repeated more than rank'):
        placement.place(a, b, poles, method='place')


@pytest.mark.parametrize('seed', range(3))
def test_multi_input_multiplicity_within_rank(seed):
    # Multiplicity 2 with 2 independent inputs is within the reach of 'place'.
    a, b = random_system(seed, 4, 2)
    poles = [-2, -2, -3, -3]
    result = placement.place(a, b, poles, method='place')
    assert_eigenvalues(a - b @ result.gain, poles)


def test_place_refuses_multiplicity_above_rank_single_input():
    a, b = random_system(0, 3, 1)
    with pytest.raises(DesignError, match=r'place: .*repeated more than rank\(B\)'):
        placement.place(a, b, [-2, -2, -3], method='place')


def test_place_refuses_multiplicity_above_rank_of_b_not_column_count():
    # Two identical input columns: rank(B) = 1 although m = 2.
    rng = np.random.default_rng(4)
    a = rng.standard_normal((3, 3))
    column = rng.standard_normal((3, 1))
    b = np.hstack([column, 2.0 * column])
    with pytest.raises(DesignError, match='repeated more than rank'):
        placement.place(a, b, [-1, -1, -2], method='place')
    result = placement.place(a, b, [-1, -1, -2])
    assert_eigenvalues(a - b @ result.gain, [-1, -1, -2])


# --------------------------------------------------------------------------------------
# Refusals.
# --------------------------------------------------------------------------------------

@pytest.mark.parametrize('method', SINGLE_INPUT_METHODS)
def test_unpaired_complex_pole(method):
    a, b = random_system(0, 3, 1)
    with pytest.raises(ConfigError, match='no conjugate'):
        placement.place(a, b, [-1 + 1j, -2, -3], method=method)
    with pytest.raises(ConfigError, match='no conjugate'):
        placement.place_observer(a, b.T, [-1 + 1j, -1 + 1j, -1 - 1j], method=method)


def test_unpaired_complex_pole_in_config_text():
    with pytest.raises(ConfigError, match='no conjugate'):
        parse_poles(['-1+2j', '-3'])
    with pytest.raises(ConfigError, match='cannot read'):
        parse_pole('minus two')
    with pytest.raises(ConfigError, match='not finite'):
        parse_pole('nan')
    with pytest.raises(ConfigError):
        parse_pole('inf')


UNCONTROLLABLE_A = np.diag([-1.0, 2.0, 3.0])
UNCONTROLLABLE_B = np.array([[1.0], [1.0], [0.0]])


@pytest.mark.parametrize('method', SINGLE_INPUT_METHODS)
def test_uncontrollable_pair_names_lost_mode(method):
    with pytest.raises(DesignError, match=r'not controllable: the modes 3 cannot be moved'):
        placement.place(UNCONTROLLABLE_A, UNCONTROLLABLE_B, [-1, -2, -4], method=method)


@pytest.mark.parametrize('method', SINGLE_INPUT_METHODS)
def test_unobservable_pair_names_lost_mode(method):
    with pytest.raises(DesignError,
                       match=r'not observable: the modes 3 cannot be seen from the outputs'):
        placement.place_observer(UNCONTROLLABLE_A, UNCONTROLLABLE_B.T, [-1, -2, -4],
                                 method=method)


@pytest.mark.parametrize('seed', range(3))
def test_hidden_uncontrollable_mode_in_random_coordinates(seed):
    # Kalman decomposition [[A11, A12], [0, 0.7]] with B = [B1; 0], in random coordinates.
    rng = np.random.default_rng(seed)
    upper = rng.standard_normal((4, 4))
    upper[3, :3] = 0.0
    upper[3, 3] = 0.7
    b_hidden = np.vstack([rng.standard_normal((3, 2)), np.zeros((1, 2))])
    transform = rng.standard_normal((4, 4)) + 3.0 * np.eye(4)
    inverse = np.linalg.inv(transform)
    a = inverse @ upper @ transform
    b = inverse @ b_hidden
    report = controllability(a, b)
    assert not report.full_rank and report.rank == 3
    assert len(report.lost_modes) == 1
    assert report.lost_modes[0] == pytest.approx(0.7, abs=1e-8)
    with pytest.raises(DesignError, match=r'the modes 0\.7 cannot be moved'):
        placement.place(a, b, [-1, -2, -3, -4])
    with pytest.raises(DesignError, match=r'0\.7'):
        require_controllable(a, b)
    # Dual: (A^T, B^T) loses the same mode for observation.
    assert pbh_lost_modes(a.T, b.T)[0] == pytest.approx(0.7, abs=1e-8)
    with pytest.raises(DesignError, match=r'not observable: the modes 0\.7 cannot be seen'):
        require_observable(a.T, b.T)
    with pytest.raises(DesignError, match=r'0\.7'):
        placement.place_observer(a.T, b.T, [-1, -2, -3, -4])


def test_lost_complex_modes_are_listed():
    # A rotation block nobody measures: both 1 +- 2j are unobservable.
    a = np.zeros((3, 3))
    a[0, 0] = -1.0
    a[1:, 1:] = [[1.0, 2.0], [-2.0, 1.0]]
    c = np.array([[1.0, 0.0, 0.0]])
    report = observability(a, c)
    assert report.rank == 1
    assert sorted(report.lost_modes, key=lambda z: z.imag) == pytest.approx([1 - 2j, 1 + 2j])
    # The message names the pair once, as the docs write it.
    with pytest.raises(DesignError, match=r'the modes 1±2j cannot be seen'):
        require_observable(a, c)


@pytest.mark.parametrize('poles', [[-1, -2], [-1, -2, -3, -4], []])
def test_wrong_pole_count(poles):
    a, b = random_system(0, 3, 1)
    with pytest.raises(ConfigError, match=f'expected 3 poles .* got {len(poles)}'):
        placement.place(a, b, poles)


@pytest.mark.parametrize('where', ['a', 'b'])
@pytest.mark.parametrize('value', [np.nan, np.inf, -np.inf])
def test_non_finite_matrix_entries(where, value):
    a, b = random_system(0, 3, 1)
    if where == 'a':
        a[1, 2] = value
    else:
        b[2, 0] = value
    with pytest.raises(ConfigError, match='finite'):
        placement.place(a, b, [-1, -2, -3])
    with pytest.raises(ConfigError, match='finite'):
        placement.place_observer(a, b.T, [-1, -2, -3])


@pytest.mark.parametrize('value', [np.nan, np.inf])
def test_non_finite_pole_is_refused(value):
    a, b = random_system(0, 3, 1)
    with pytest.raises(ValueError):
        placement.place(a, b, [value, -2, -3])


@pytest.mark.parametrize('method', ['acker', 'direct', 'canonical'])
def test_single_input_methods_refuse_two_inputs(method):
    a, b = random_system(0, 3, 2)
    with pytest.raises(ConfigError, match='single input'):
        placement.place(a, b, [-1, -2, -3], method=method)


def test_unknown_method_and_bad_shapes():
    a, b = random_system(0, 3, 1)
    with pytest.raises(ConfigError, match='method'):
        placement.place(a, b, [-1, -2, -3], method='pole_place')
    with pytest.raises(ConfigError, match='square'):
        placement.place(a[:, :2], b, [-1, -2, -3])
    with pytest.raises(ConfigError, match='expected 3 rows'):
        placement.place(a, b[:2], [-1, -2, -3])


# --------------------------------------------------------------------------------------
# Property: whatever place returns is right.
# --------------------------------------------------------------------------------------

_ENTRY = st.floats(min_value=-5.0, max_value=5.0, allow_nan=False, allow_infinity=False,
                   width=32)
_REAL_POLES = st.sampled_from([-0.5, -1.0, -2.0, -3.0, -4.5, -7.0, -10.0])
_PAIRS = st.tuples(st.sampled_from([-1.0, -2.5, -4.0]), st.sampled_from([1.0, 2.0, 3.5]))


@st.composite
def placement_problems(draw):
    """Draw ``(A, B, poles, method)``: small random matrices, grid poles (maybe repeated)."""
    n_states = draw(st.integers(min_value=1, max_value=4))
    n_inputs = draw(st.integers(min_value=1, max_value=2))
    a = np.array(draw(st.lists(_ENTRY, min_size=n_states ** 2, max_size=n_states ** 2)),
                 dtype=float).reshape(n_states, n_states)
    b = np.array(draw(st.lists(_ENTRY, min_size=n_states * n_inputs,
                               max_size=n_states * n_inputs)),
                 dtype=float).reshape(n_states, n_inputs)
    n_pairs = draw(st.integers(min_value=0, max_value=n_states // 2))
    poles = []
    for _ in range(n_pairs):
        real, imag = draw(_PAIRS)
        poles += [complex(real, imag), complex(real, -imag)]
    poles += [complex(draw(_REAL_POLES)) for _ in range(n_states - 2 * n_pairs)]
    methods = SINGLE_INPUT_METHODS if n_inputs == 1 else MULTI_INPUT_METHODS
    return a, b, np.array(poles), draw(st.sampled_from(methods))


@settings(max_examples=30, deadline=None, database=None,
          suppress_health_check=[HealthCheck.too_slow])
@given(placement_problems())
def test_place_never_returns_a_wrong_gain(problem):
    a, b, poles, method = problem
    try:
        result = placement.place(a, b, poles, method=method)
    except DesignError:
        return
    assert result.gain.shape == b.shape[::-1]
    assert np.all(np.isfinite(result.gain))
    assert_eigenvalues(a - b @ result.gain, poles, rtol=2e-6)


def test_auto_takes_vargas_method_first_for_large_systems():
    # The robust (Tits-Yang) iterations cost seconds per iteration at n = 100; above
    # LARGE_STATES 'auto' starts with Varga's Schur method and still verifies the result.
    rng = np.random.default_rng(5)
    n, p = placement.LARGE_STATES + 6, 3
    a = rng.standard_normal((n, n)) / np.sqrt(n) - 2.0 * np.eye(n)
    c = rng.standard_normal((p, n))
    poles = np.linalg.eigvals(a) - 0.5
    result = placement.place_observer(a, c, poles)
    assert result.method == 'varga' and result.residual <= 1e-6
    np.testing.assert_allclose(match(np.linalg.eigvals(a - result.gain @ c), poles), poles,
                               rtol=1e-6)
