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

"""The observer types: each in its package, found by entry point, asked by capability."""

import io
from pathlib import Path
import tokenize

import pytest

from conftest import REPOSITORY
from observer_ros.config import validate_parameters
from observer_ros.core.errors import ConfigError
from observer_ros.core.observers import GROUP, observer_type, observer_types, plugin_failures

PACKAGE = REPOSITORY / 'observer_ros'
BUILT_IN = ('full_order', 'reduced_order', 'chen', 'kalman')
NONLINEAR = ('extended_kalman', 'unscented_kalman')  # filters of core.nonlinear


def test_the_built_in_types_come_from_the_entry_point_group_in_priority_order():
    from importlib.metadata import entry_points
    assert {e.name for e in entry_points(group=GROUP)} >= set(BUILT_IN)
    kinds = observer_types()
    assert tuple(kind.name for kind in kinds) == BUILT_IN + NONLINEAR
    assert [kind.priority for kind in kinds] == sorted((k.priority for k in kinds),
                                                       reverse=True)
    assert plugin_failures() == {}


def test_no_module_outside_a_type_package_decides_by_a_type_name():
    # A string literal that is a type's name outside that type's package is a decision by
    # name (``kind == 'kalman'``); the capabilities say what a type can do instead.
    names = {kind.name for kind in observer_types()}
    found = []
    for path in PACKAGE.rglob('*.py'):
        relative = path.relative_to(PACKAGE).parts
        own = (relative[:2] == ('core', 'observers') and len(relative) > 3
               and relative[2] in names)
        tokens = tokenize.generate_tokens(io.StringIO(path.read_text(encoding='utf-8')).readline)
        for token in tokens:
            if token.type == tokenize.STRING and token.string.strip('\'"') in names and not own:
                found.append(f'{path.relative_to(REPOSITORY)}:{token.start[0]} {token.string}')
    assert found == []


@pytest.mark.parametrize('name, covariance, every_output', [
    ('full_order', False, False), ('reduced_order', False, True), ('chen', False, True),
    ('kalman', True, False)])
def test_capabilities_of_the_built_in_types(name, covariance, every_output):
    capabilities = observer_type(name).capabilities
    assert capabilities.covariance is covariance
    assert capabilities.needs_every_output is every_output
    assert capabilities.linear_realization is True
    # Several sources: the types that update with some of the outputs (a design per subset).
    assert capabilities.several_sources is not every_output


def test_an_unknown_type_lists_the_registered_ones():
    with pytest.raises(ConfigError, match=r'^observer.type: expected one of full_order, '
                                          r'reduced_order, chen, kalman, extended_kalman, '
                                          r"unscented_kalman, got 'luenberger'$"):
        validate_parameters({'model.A': [0.0], 'model.B': [1.0], 'model.C': [1.0],
                             'observer.type': 'luenberger'})


def test_a_failed_design_is_charged_to_the_argument_the_type_names():
    params = {'model.A': [0.0, 1.0, 0.0, 0.0], 'model.B': [0.0, 1.0], 'model.C': [0.0, 1.0]}
    with pytest.raises(ConfigError, match=r'^observer.(poles|gain)'):
        validate_parameters(dict(params, **{'observer.poles': ['-1', '-2']}))
    assert observer_type('kalman').charged_argument({}) == 'process_noise'
    assert observer_type('chen').charged_argument({'gain': [1.0]}) == 'gain'


def test_each_type_is_one_package():
    for name in BUILT_IN:
        assert {p.name for p in (PACKAGE / 'core' / 'observers' / name).glob('*.py')} >= {
            '__init__.py', 'design.py', 'estimator.py'}
    assert not Path(PACKAGE / 'core' / 'design' / 'kalman.py').exists()
