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
Each parameter converted once, at the edge, into its final type and unit.

One seconds-to-nanoseconds rule (:mod:`observer_ros.core.units`), checked on its edge
values and used everywhere in the package.
"""

import re

import pytest

from conftest import REPOSITORY
from observer_ros.core.errors import ConfigError
from observer_ros.core.units import NANOSECONDS, rate_to_period_ns, seconds_to_ns

PACKAGE = REPOSITORY / 'observer_ros'

#: A seconds-to-nanoseconds conversion written in place: a product with ``1e9`` or
#: ``10**9``, a rounding or truncation of a product with (or a quotient of) NANOSECONDS.
INLINE_CONVERSION = re.compile(
    r'\*\s*1e9\b|\b1e9\s*\*|\*\s*10\s*\*\*\s*9\b|\b10\s*\*\*\s*9\s*\*|1_000_000_000'
    r'|\b(?:round|int)\([^()]*\*\s*NANOSECONDS\b|\b(?:round|int)\(\s*NANOSECONDS\s*/')

#: The stamp codec's integer ``sec``/``nanosec`` arithmetic, which the wire package
#: (issue 28, another change) keeps; everything else asks core.units.
WIRE_CODEC = ('ros/cdr.py', 'wire/')


@pytest.mark.parametrize('seconds, expected', [
    (0, 0), (0.0, 0), (-0.0, 0), (2, 2 * NANOSECONDS),
    (1e-9, 1), (-1e-9, -1), (0.999999999, 999_999_999), (1.000000001, 1_000_000_001),
    (0.4e-9, 0), (0.6e-9, 1), (0.5e-9, 0), (1.5e-9, 2), (2.5e-9, 2), (-0.5e-9, 0),
    (-1.5e-9, -2), (7e-9, 7), (0.3, 300_000_000), (0.01, 10_000_000),
    (3600.001, 3_600_001_000_000), (1e12, 10 ** 21), (-1e12, -10 ** 21),
])
def test_seconds_become_the_nearest_nanosecond_ties_to_even(seconds, expected):
    converted = seconds_to_ns(seconds)
    assert converted == expected and type(converted) is int


@pytest.mark.parametrize('seconds', [float('inf'), float('-inf'), float('nan'), 1e300])
def test_seconds_that_are_not_finite_in_nanoseconds_are_refused_by_name(seconds):
    with pytest.raises(ConfigError, match=r'^observer.max_gap: expected a finite number of '
                       r'seconds, got'):
        seconds_to_ns(seconds, 'observer.max_gap')


@pytest.mark.parametrize('rate, expected', [
    (100.0, 10_000_000), (3.0, 333_333_333), (30.0, 33_333_333), (1e9, 1), (3e9, 0),
    (0.01, 100 * NANOSECONDS)])
def test_a_rate_becomes_its_period_in_nanoseconds(rate, expected):
    assert rate_to_period_ns(rate) == expected


@pytest.mark.parametrize('rate', [0.0, -1.0, float('inf'), float('nan')])
def test_a_rate_that_has_no_period_is_refused_by_name(rate):
    with pytest.raises(ConfigError, match=r'^plant.rate_hz: expected a finite rate above 0'):
        rate_to_period_ns(rate, 'plant.rate_hz')


def test_the_package_converts_seconds_to_nanoseconds_with_the_one_rule_only():
    found = []
    for path in sorted(PACKAGE.rglob('*.py')):
        relative = path.relative_to(PACKAGE).as_posix()
        if relative == 'core/units.py' or relative.startswith(WIRE_CODEC):
            continue
        for number, line in enumerate(path.read_text(encoding='utf-8').splitlines(), 1):
            if INLINE_CONVERSION.search(line.split('#')[0]):
                found.append(f'{relative}:{number}: {line.strip()}')
    assert not found, 'convert with core.units.seconds_to_ns / rate_to_period_ns:\n' + (
        '\n'.join(found))
