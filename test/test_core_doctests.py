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
The core as a library: its flat namespace, its documentation and the examples in it.

Every example in the core's docstrings runs here (doctest), so what a notebook user copies
from the documentation works.
"""

import doctest
import importlib
import inspect
import subprocess
import sys

import numpy as np
import pytest

import observer_ros.core as oc

#: The modules whose docstrings carry the namespace's documentation and examples.
DOCUMENTED_MODULES = (
    'observer_ros.core',
    'observer_ros.core.errors',
    'observer_ros.core.model',
    'observer_ros.core.control_conversion',
    'observer_ros.core.flat_matrices',
    'observer_ros.core.discretize',
    'observer_ros.core.ranks',
    'observer_ros.core.analysis',
    'observer_ros.core.poles',
    'observer_ros.core.placement',
    'observer_ros.core.placement_checks',
    'observer_ros.core.placement_methods',
    'observer_ros.core.design.common',
    'observer_ros.core.observers.full_order.design',
    'observer_ros.core.observers.reduced_order.design',
    'observer_ros.core.observers.chen.sylvester',
    'observer_ros.core.observers.chen.design',
    'observer_ros.core.observers.kalman.design',
    'observer_ros.core.design.feedback',
    'observer_ros.core.loop_analysis.transfer_function',
    'observer_ros.core.loop_analysis.observer_controller',
    'observer_ros.core.loop_analysis.diophantine',
    'observer_ros.core.loop_analysis.closed_loop',
    'observer_ros.core.feedback_law',
    'observer_ros.core.consistency',
    'observer_ros.core.units',
    'observer_ros.core.simulation',
    'observer_ros.core.disturbance_model',
    'observer_ros.core.disturbances',
    'observer_ros.core.evaluation',
    'observer_ros.core.arguments',
    'observer_ros.core.observers',
    'observer_ros.core.estimators.constant_gain',
    'observer_ros.core.estimators.intervals',
    'observer_ros.core.events.engine',
    'observer_ros.core.rules',
    'observer_ros.core.estimates',
    'observer_ros.core.estimators.protocol',
    'observer_ros.core.estimators.vectors',
    'observer_ros.core.observers.kalman.time_varying',
    'observer_ros.core.streaming.stream',
    'observer_ros.core.streaming.recorded',
    'observer_ros.core.tuning.innovations',
    'observer_ros.core.tuning.noise_model',
    'observer_ros.core.tuning.als',
    'observer_ros.core.tuning.identified_model',
    'observer_ros.core.tuning.subspace',
)


@pytest.mark.parametrize('name', DOCUMENTED_MODULES)
def test_docstring_examples_run(name):
    module = importlib.import_module(name)
    printoptions = np.get_printoptions()
    try:
        result = doctest.testmod(module, optionflags=doctest.NORMALIZE_WHITESPACE,
                                 raise_on_error=False, report=True)
    finally:
        np.set_printoptions(**printoptions)
    assert result.failed == 0, f'{result.failed} of {result.attempted} examples failed'
    assert result.attempted > 0


def _public_objects():
    for name in oc.__all__:
        value = getattr(oc, name)
        if inspect.isclass(value) or inspect.isfunction(value):
            yield name, value


def test_every_public_name_is_documented_in_numpydoc_sections():
    missing = []
    for name, value in _public_objects():
        doc = inspect.getdoc(value) or ''
        sections = {line.strip() for line in doc.splitlines()}
        wanted = {'Examples'}
        if inspect.isfunction(value):
            signature = inspect.signature(value)
            if signature.parameters:
                wanted.add('Parameters')
            if signature.return_annotation not in (None, 'None'):
                wanted.add('Returns')
            if 'raise ' in inspect.getsource(value):
                wanted.add('Raises')
        elif not issubclass(value, BaseException) and not (
                {'Parameters', 'Attributes'} & sections):
            wanted.add('Parameters or Attributes')
        missing.extend(f'{name}: {section}' for section in sorted(wanted - sections))
    assert not missing, missing


def test_namespace_lists_what_it_exports():
    assert oc.__all__ == sorted(set(oc.__all__))
    for name in oc.__all__:
        value = getattr(oc, name)
        assert value is getattr(importlib.import_module(oc._MODULE_OF[name]), name)
        assert name in dir(oc)
    with pytest.raises(AttributeError, match='no_such_name'):
        oc.no_such_name  # noqa: B018


def test_import_is_cheap_and_loads_python_control_only_when_asked():
    script = (
        'import sys\n'
        'import observer_ros.core as oc\n'
        "print(sorted(m for m in ('scipy', 'control') if m in sys.modules))\n"
        'for name in oc.__all__:\n'
        '    getattr(oc, name)\n'
        "print('control' in sys.modules)\n"
        'oc.StateSpaceModel.from_flat([0.0], [1.0], [1.0]).to_statespace()\n'
        "print('control' in sys.modules)\n")
    result = subprocess.run([sys.executable, '-c', script], capture_output=True, text=True,
                            check=True)
    assert result.stdout.split() == ['[]', 'False', 'True']
