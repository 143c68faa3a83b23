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

"""The ROS-free health checks: input rates and ages, NIS windows, counters, configuration."""

import re

import numpy as np
import pytest
import scipy.stats

from conftest import CONFIG_DIR
from observer_ros.app.design_check import configuration_check
from observer_ros.app.health import (
    combine, CounterWatch, covariance_values, ERROR, innovation_values, InputMonitor,
    nis_findings, OK, stale_timeout, WARN)
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.consistency import nis_bounds, NisWindow
from observer_ros.core.errors import ConfigError
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.simulation import PlantSimulator
from observer_ros.core.units import NANOSECONDS

PERIOD_NS = 10_000_000
KALMAN = load_parameter_file(str(CONFIG_DIR / 'kalman_noisy.yaml'))


@pytest.mark.parametrize('window, outputs', [(50, 1), (20, 2), (200, 3)])
def test_nis_bounds_hold_the_stated_share_of_consistent_windows(window, outputs):
    rng = np.random.default_rng(7)
    low, high = nis_bounds(window, outputs, 0.99)
    assert low < outputs < high
    means = rng.chisquare(outputs, size=(20000, window)).mean(axis=1)
    outside = np.mean((means < low) | (means > high))
    assert 0.005 < outside < 0.015, outside
    assert np.mean(means > high) == pytest.approx(0.005, abs=0.003)
    wider = nis_bounds(window, outputs, 0.999)
    assert wider[0] < low and wider[1] > high
    assert high == pytest.approx(scipy.stats.chi2.ppf(0.995, window * outputs) / window)


@pytest.mark.parametrize('args, name', [((0, 1), 'window'), ((5, 0), 'outputs'),
                                        ((5, 1, 1.0), 'confidence')])
def test_nis_bounds_refuse_bad_arguments_naming_them(args, name):
    with pytest.raises(ValueError, match=f'^{name}: expected'):
        nis_bounds(*args)


def test_nis_window_waits_until_full_then_judges_both_sides():
    window = NisWindow(50, 1, 0.99)
    rng = np.random.default_rng(3)
    for value in rng.chisquare(1, 49):
        window.add(value)
    assert nis_findings(window)[0] == []  # filling: not judged yet
    window.add(1.0)
    found, values = nis_findings(window)
    assert found == [], values
    for value in 100 * rng.chisquare(1, 50):  # R 100 times too small
        window.add(value)
    (level, text), = nis_findings(window)[0]
    assert level == WARN
    assert text.startswith('NIS mean ') and 'above the 99% bound 1.59 over 50 samples' in text
    assert text.endswith('R or Q too small (or a model error)')
    for value in 0.01 * rng.chisquare(1, 50):  # R 100 times too large
        window.add(value)
    (level, text), = nis_findings(window)[0]
    assert level == WARN and 'below the 99% bound 0.56' in text and 'R or Q too large' in text
    window.add(float('nan'))
    assert nis_findings(window)[0][0][0] == ERROR


@pytest.mark.parametrize('measurement_noise, expected', [(1e-4, OK), (1e-2, WARN)])
def test_kalman_nis_window_flags_a_measurement_noise_larger_than_configured(
        measurement_noise, expected):
    system = validate_parameters(KALMAN)
    stream = system.make_stream()
    simulator = PlantSimulator(system.model, [1.0, 0.0], [0.0, 0.04], [measurement_noise],
                               seed=11)
    window = NisWindow(50, 1, 0.99)
    levels = []
    for k in range(400):
        stamp = k * PERIOD_NS
        y = simulator.measure()
        samples = stream.add_input(stamp, [0.0]) + stream.add_measurement(stamp, y)
        simulator.step(np.zeros(1), PERIOD_NS / NANOSECONDS)
        for sample in samples:
            window.add(sample.nis)
        if k >= 50 and k % 25 == 0:
            findings = nis_findings(window)[0]
            levels.append(findings[0][0] if findings else OK)
    assert set(levels) == {expected}, levels


def test_input_monitor_rate_stale_and_recovery_messages():
    monitor = InputMonitor('y', 100.0, stale_timeout(0.0, 100.0), tolerance=0.5)
    monitor.start(0)
    found, _ = monitor.findings(NANOSECONDS // 10)
    assert found == [(WARN, 'no y received yet in 0.1 s (expected every 0.01 s)')]
    assert monitor.findings(NANOSECONDS)[0][0][0] == ERROR  # nothing after the stale timeout
    now = NANOSECONDS
    for k in range(100):  # 100 Hz by the stamps, whatever the arrival jitter
        now += PERIOD_NS + (3_000_000 if k % 2 else -3_000_000)
        monitor.tick(k * PERIOD_NS, now)
    found, values = monitor.findings(now)
    assert found == []
    assert dict(values)['y.rate_hz'] == '100' and dict(values)['y.count'] == 100
    later = now + 2_300_000_000
    assert monitor.findings(later)[0] == [(ERROR, 'y stale for 2.3 s (expected every 0.01 s)')]
    for k in range(100, 140):  # back, at 40 Hz
        later += 25_000_000
        monitor.tick(99 * PERIOD_NS + (k - 99) * 25_000_000, later)
    assert monitor.findings(later)[0] == [(WARN, 'y at 40 Hz, expected 100 Hz (+-50%)')]
    for k in range(100):
        later += PERIOD_NS
        monitor.tick(k * PERIOD_NS + 10 * NANOSECONDS, later)
    assert monitor.findings(later)[0] == []


def test_input_monitor_minimum_only_and_optional_inputs():
    fast = InputMonitor('x_hat', 100.0, 0.5, minimum_only=True)
    two_sided = InputMonitor('y', 100.0, 0.5)
    for k in range(200):  # 200 Hz
        fast.tick(k * 5_000_000, k * 5_000_000)
        two_sided.tick(k * 5_000_000, k * 5_000_000)
    assert fast.findings(NANOSECONDS)[0] == []
    assert two_sided.findings(NANOSECONDS)[0][0][0] == WARN
    optional = InputMonitor('reference', None, 0.5, required=False)
    optional.start(0)
    assert optional.findings(10 * NANOSECONDS)[0] == []
    optional.tick(0, 0)
    assert optional.findings(10 * NANOSECONDS)[0] == [
        (OK, 'reference stale for 10 s')]


def test_stale_timeout_is_configured_or_ten_periods_at_least_half_a_second():
    assert stale_timeout(2.0, 100.0) == 2.0
    assert stale_timeout(0.0, 100.0) == 0.5
    assert stale_timeout(0.0, 1.0) == 10.0
    assert stale_timeout(0.0, None) == 0.5


def test_counter_watch_warns_once_per_growth_by_reason():
    watch = CounterWatch(('future_stamp', 'malformed'), 'data dropped or repaired')
    assert watch.findings({'future_stamp': 0, 'measurements': 5}) == []
    assert watch.findings({'future_stamp': 2, 'malformed': 1}) == [
        (WARN, 'data dropped or repaired since the last report: 2 future_stamp, 1 malformed')]
    assert watch.findings({'future_stamp': 2, 'malformed': 1}) == []


def test_combine_keeps_the_worst_level_and_its_messages():
    check = combine('inputs', [(WARN, 'a'), (ERROR, 'b'), (ERROR, 'c'), (OK, 'd')],
                    [('k', 1)])
    assert (check.level, check.message, check.values) == (ERROR, 'b; c', (('k', '1'),))
    assert combine('inputs', [], []).message == 'ok'


def test_configuration_check_reports_poles_and_flags_what_cannot_work():
    model = StateSpaceModel.from_matrices([[0, 1], [-4, -0.4]], [[0], [1]], [[1, 0]])
    check = configuration_check(model, 'full_order', [-8, -9], [-3 + 2j, -3 - 2j],
                                [-8, -9, -3 + 2j, -3 - 2j])
    values = dict(check.values)
    assert check.level == OK and check.message == 'ok'
    assert values['observable'] == 'true' and values['observer_type'] == 'full_order'
    assert values['observer_poles'] == '-8, -9'
    assert values['closed_loop_poles'] == '-8, -9, -3+2j, -3-2j'
    blind = StateSpaceModel.from_matrices([[1, 0], [0, 2]], [[1], [1]], [[1, 0]])
    check = configuration_check(blind, 'full_order', [-1, -2])
    assert check.level == ERROR and 'modes 2 cannot be seen' in check.message
    unstable = configuration_check(model, 'full_order', [-8, -9], None, [-8, 0.5],
                                   notes=('the controller is unstable',))
    assert unstable.level == ERROR and unstable.message == 'the closed loop is unstable'
    noted = configuration_check(model, 'full_order', [-8, -9],
                                notes=('the controller is unstable',))
    assert (noted.level, noted.message) == (WARN, 'the controller is unstable')


def test_innovation_and_covariance_values():
    assert innovation_values([])[0] == []
    found, values = innovation_values([4.0, 9.0])
    assert found == [] and dict(values)['innovation.norm'] == '3'
    assert innovation_values([float('inf')])[0][0][0] == ERROR
    assert covariance_values(None) == ([], [])
    assert covariance_values(0.25)[1] == [('covariance.trace', '0.25')]
    assert covariance_values(float('nan'))[0][0][0] == ERROR


@pytest.mark.parametrize('name, value, expected', [
    ('diagnostics.period', -1.0, 'expected seconds in [0, 3600]'),
    ('diagnostics.nis_window', 1, 'expected a count in [2, 100000]'),
    ('diagnostics.nis_confidence', 1.0, 'expected'),
    ('diagnostics.rate_tolerance', 0.0, 'expected')])
def test_diagnostics_parameters_are_range_checked(name, value, expected):
    with pytest.raises(ConfigError, match='^' + re.escape(f'{name}: {expected}')):
        validate_parameters(dict(KALMAN, **{name: value}))
    assert validate_parameters(dict(KALMAN, **{'diagnostics.period': 0.0}))
