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
Core functions name their own arguments in their errors, in a structured form.

``ConfigError`` and ``DesignError`` carry ``parameter`` (the argument, in the words of the
function that raised) and ``reason`` (the message without it), so a boundary can map the
argument to its own parameter name without editing the text.
"""

import ast
import inspect
from pathlib import Path
import pickle
import re

import numpy as np
import pytest

import observer_ros.core as oc
from observer_ros.core.errors import ConfigError, DesignError

CORE = Path(oc.__file__).parent

#: The state-space fields errors may name besides a function's own arguments.
MATRICES = {'A', 'B', 'C', 'D'}
MODEL_FIELDS = MATRICES | {'dt', 'state_names', 'input_names', 'output_names'}

DI = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
THIRD = oc.StateSpaceModel.from_matrices([[-3, 1, 0], [0, -1, 1], [0, 0, -2]],
                                         [[0], [0], [1]], [[1, 0, 0]])
MIMO = oc.StateSpaceModel.from_matrices(-np.eye(2), np.eye(2), np.eye(2))
DISCRETE = oc.StateSpaceModel.from_matrices([[1, 0.1], [0, 1]], [[0], [0.1]], [[1, 0]],
                                            dt=0.1)
EYE2 = [1, 0, 0, 1]


class TransferFunctionLike:
    """Has no A, B, C, D: not a state-space system."""

    dt = 0


class UnspecifiedPeriod:
    """A state-space system with python-control's ``dt=True`` (discrete, no period)."""

    A, B, C, D, dt = [[0.5]], [[1.0]], [[1.0]], [[0.0]], True


# (function, call, error class, argument named)
CASES = [
    (oc.StateSpaceModel.from_flat, lambda: oc.StateSpaceModel.from_flat([1, 2, 3], [1], [1]),
     ConfigError, 'A'),
    (oc.StateSpaceModel.from_flat, lambda: oc.StateSpaceModel.from_flat(EYE2, [1, 2, 3], [1]),
     ConfigError, 'B'),
    (oc.StateSpaceModel.from_flat, lambda: oc.StateSpaceModel.from_flat(EYE2, [1, 2], [1]),
     ConfigError, 'C'),
    (oc.StateSpaceModel.from_flat,
     lambda: oc.StateSpaceModel.from_flat(EYE2, [1, 2], [1, 0], [1, 2]), ConfigError, 'D'),
    (oc.StateSpaceModel.from_flat,
     lambda: oc.StateSpaceModel.from_flat(EYE2, [1, 2], [1, 0], dt=-1), ConfigError, 'dt'),
    (oc.StateSpaceModel.from_flat,
     lambda: oc.StateSpaceModel.from_flat(EYE2, [1, 2], [1, 0], state_names=['x']),
     ConfigError, 'state_names'),
    (oc.StateSpaceModel.from_flat,
     lambda: oc.StateSpaceModel.from_flat(EYE2, [1, 2], [1, 0], input_names=['u', 'v']),
     ConfigError, 'input_names'),
    (oc.StateSpaceModel.from_flat,
     lambda: oc.StateSpaceModel.from_flat(EYE2, [1, 2], [1, 0], output_names='y'),
     ConfigError, 'output_names'),
    (oc.StateSpaceModel.from_matrices,
     lambda: oc.StateSpaceModel.from_matrices([[1, 2]], [[1]], [[1]]), ConfigError, 'A'),
    (oc.StateSpaceModel.from_matrices,
     lambda: oc.StateSpaceModel.from_matrices(np.eye(2), [[1, 2]], [[1, 0]]),
     ConfigError, 'B'),
    (oc.StateSpaceModel.from_matrices,
     lambda: oc.StateSpaceModel.from_matrices(np.eye(2), [[1], [2]], [[1, 0, 0]]),
     ConfigError, 'C'),
    (oc.StateSpaceModel.from_matrices,
     lambda: oc.StateSpaceModel.from_matrices(np.eye(2), [[1], [2]], [[1, 0]], [[1, 2]]),
     ConfigError, 'D'),
    (oc.StateSpaceModel.from_statespace,
     lambda: oc.StateSpaceModel.from_statespace(TransferFunctionLike()), ConfigError, 'sys'),
    (oc.StateSpaceModel.from_statespace,
     lambda: oc.StateSpaceModel.from_statespace(UnspecifiedPeriod()), ConfigError, 'sys'),
    (oc.StateSpaceModel.transformed, lambda: DI.transformed(np.zeros((2, 2))),
     ConfigError, 'transform'),
    (oc.observability, lambda: oc.observability(np.eye(2), [[1, 0, 0]]), ConfigError, 'C'),
    (oc.controllability, lambda: oc.controllability(np.eye(2), [[1, 0]]), ConfigError, 'B'),
    (oc.place, lambda: oc.place([[1, 2]], [[1]], [-1]), ConfigError, 'A'),
    (oc.place, lambda: oc.place(DI.a, [[1]], [-1, -2]), ConfigError, 'B'),
    (oc.place, lambda: oc.place(DI.a, DI.b, [-1]), ConfigError, 'poles'),
    (oc.place, lambda: oc.place(DI.a, DI.b, [-1, -2], method='magic'), ConfigError, 'method'),
    (oc.place, lambda: oc.place(DI.a, DI.b, [-1, -2], rtol=0), ConfigError, 'rtol'),
    (oc.place_observer, lambda: oc.place_observer(DI.a, [[1, 0, 0]], [-1, -2]),
     ConfigError, 'C'),
    (oc.parse_poles, lambda: oc.parse_poles(['-1+2j']), ConfigError, 'poles'),
    (oc.slowest_allowed_pole, lambda: oc.slowest_allowed_pole(2.0, 1.0),
     ConfigError, 'tolerance'),
    (oc.slowest_allowed_pole, lambda: oc.slowest_allowed_pole(0.1, 0.0), ConfigError, 'time'),
    (oc.poles_meeting_error_spec, lambda: oc.poles_meeting_error_spec(0.1, 1.0, 0),
     ConfigError, 'count'),
    (oc.poles_meeting_error_spec,
     lambda: oc.poles_meeting_error_spec(0.1, 1.0, 2, spacing=-1.0), ConfigError, 'spacing'),
    (oc.zero_order_hold, lambda: oc.zero_order_hold(DI.a, DI.b, 0.0), ConfigError, 'dt'),
    (oc.van_loan, lambda: oc.van_loan(DI.a, np.eye(2), -1.0), ConfigError, 'dt'),
    (oc.design_full_order, lambda: oc.design_full_order(DI, gain=[1, 2, 3]),
     ConfigError, 'gain'),
    (oc.design_full_order, lambda: oc.design_full_order(DI, gain=[0, 0]), DesignError, 'gain'),
    (oc.design_full_order, lambda: oc.design_full_order(DI, poles=[-1, 2]),
     DesignError, 'poles'),
    (oc.design_full_order, lambda: oc.design_full_order(DI, poles=[-1, -2, -3]),
     ConfigError, 'poles'),
    (oc.design_full_order, lambda: oc.design_full_order(DI), ConfigError, 'poles'),
    (oc.design_full_order, lambda: oc.design_full_order(DI, poles=[-1, -2], method='magic'),
     ConfigError, 'method'),
    (oc.design_reduced_order,
     lambda: oc.design_reduced_order(DI, poles=[-1], coordinates='modal'),
     ConfigError, 'coordinates'),
    (oc.design_reduced_order,
     lambda: oc.design_reduced_order(MIMO, poles=[]), DesignError, 'C'),
    (oc.design_reduced_order, lambda: oc.design_reduced_order(DI, poles=[-1, -2]),
     ConfigError, 'poles'),
    (oc.design_reduced_order, lambda: oc.design_reduced_order(DI, poles=[1]),
     DesignError, 'poles'),
    (oc.design_reduced_order, lambda: oc.design_reduced_order(DI, gain=[1, 2]),
     ConfigError, 'gain'),
    (oc.design_reduced_order, lambda: oc.design_reduced_order(DI, gain=[-1]),
     DesignError, 'gain'),
    (oc.design_reduced_order, lambda: oc.design_reduced_order(DI), ConfigError, 'poles'),
    (oc.design_chen, lambda: oc.design_chen(MIMO, poles=[]), DesignError, 'C'),
    (oc.design_chen, lambda: oc.design_chen(THIRD, poles=[-10]), ConfigError, 'poles'),
    (oc.design_chen, lambda: oc.design_chen(THIRD, poles=[-10, 1]), DesignError, 'poles'),
    (oc.design_chen, lambda: oc.design_chen(THIRD, poles=[-3, -10]), DesignError, 'poles'),
    (oc.design_chen, lambda: oc.design_chen(THIRD, poles=[-10, -12], gain=[1, 2, 3]),
     ConfigError, 'gain'),
    (oc.design_chen, lambda: oc.design_chen(THIRD, poles=[-10, -12], gain=[1, 0]),
     DesignError, 'gain'),
    (oc.design_kalman, lambda: oc.design_kalman(DI, [1, 1, 1], [1]),
     ConfigError, 'process_noise'),
    (oc.design_kalman, lambda: oc.design_kalman(DI, [1, 1], [0]),
     ConfigError, 'measurement_noise'),
    (oc.design_sampled_kalman, lambda: oc.design_sampled_kalman(DISCRETE, [1, 1], [1], 0.1),
     ConfigError, 'model'),
    (oc.design_sampled_kalman, lambda: oc.design_sampled_kalman(DI, [1, 1], [1], 0.0),
     ConfigError, 'dt'),
    (oc.design_feedback, lambda: oc.design_feedback(DI, gain=[1]), ConfigError, 'gain'),
    (oc.design_feedback, lambda: oc.design_feedback(DI, gain=[0, 0]), DesignError, 'gain'),
    (oc.design_feedback, lambda: oc.design_feedback(DI, poles=[1, -2]),
     ConfigError, 'poles'),
    (oc.design_feedback, lambda: oc.design_feedback(DI), ConfigError, 'poles'),
    (oc.controller_transfer_function,
     lambda: oc.controller_transfer_function(
         MIMO, oc.design_full_order(MIMO, poles=[-3, -4]).realization, np.eye(2)),
     DesignError, 'model'),
    (oc.diophantine_controller, lambda: oc.diophantine_controller(MIMO, [-1, -2], [-3, -4]),
     DesignError, 'model'),
    (oc.solve_diophantine, lambda: oc.solve_diophantine([1, 0, 0], [1], [1, 2, 3]),
     DesignError, 'closed_loop_poly'),
    (oc.PlantSimulator, lambda: oc.PlantSimulator(DI, initial_state=[1, 2, 3]),
     ConfigError, 'initial_state'),
    (oc.PlantSimulator, lambda: oc.PlantSimulator(DI, process_noise=[1, -1]),
     ConfigError, 'process_noise'),
    (oc.PlantSimulator, lambda: oc.PlantSimulator(DI, measurement_noise=[1, 2]),
     ConfigError, 'measurement_noise'),
    (oc.PlantSimulator, lambda: oc.PlantSimulator(DI, input_limits=[1, -1]),
     ConfigError, 'input_limits'),
    (oc.StateFeedbackLaw, lambda: oc.StateFeedbackLaw([[1, 2]], reference_gain=[[1], [2]]),
     ConfigError, 'reference_gain'),
    (oc.StateFeedbackLaw, lambda: oc.StateFeedbackLaw([[1, 2]], input_limits=[1, 2, 3]),
     ConfigError, 'input_limits'),
    (oc.error_report, lambda: oc.error_report([], [], [], (), 1.0), ConfigError, 'stamps_ns'),
    (oc.error_report,
     lambda: oc.error_report([0, 1], np.zeros((2, 2)), np.zeros((2, 3)), ('a', 'b'), 1.0),
     ConfigError, 'estimate'),
]


def _arguments(function) -> set:
    parameters = inspect.signature(function).parameters
    names = set(parameters) - {'self', 'cls'}
    if 'parameter' in parameters:  # helpers report the name their caller gives
        names.add(parameters['parameter'].default)
    if names & {'a', 'b', 'c', 'd'}:
        names |= {name.upper() for name in names & {'a', 'b', 'c', 'd'}}
    if 'model' in names or function.__qualname__.startswith('StateSpaceModel.'):
        names |= MODEL_FIELDS
    return names


@pytest.mark.parametrize('function, call, error, parameter', CASES,
                         ids=[f'{case[0].__qualname__}-{case[3]}-{index}'
                              for index, case in enumerate(CASES)])
def test_errors_name_the_functions_own_argument(function, call, error, parameter):
    with pytest.raises(error) as info:
        call()
    raised = info.value
    assert raised.parameter == parameter
    assert str(raised) == f'{parameter}: {raised.reason}'
    assert parameter in _arguments(function), (parameter, sorted(_arguments(function)))
    assert raised.reason and not re.match(r'\w+(\.\w+)*: ', raised.reason), raised.reason
    assert not re.search(r'\b(observer|feedback|plant|model)\.[a-z_]+\b', raised.reason), (
        raised.reason)


def test_pair_failures_are_unnamed():
    # An unobservable or uncontrollable pair is no single argument's fault.
    unobservable = oc.StateSpaceModel.from_matrices(np.diag([-1.0, -2.0]), [[1], [1]],
                                                    [[1, 0]])
    for call in (lambda: oc.design_full_order(unobservable, poles=[-3, -4]),
                 lambda: oc.require_observable(unobservable.a, unobservable.c),
                 lambda: oc.place(np.diag([-1.0, -2.0]), [[1], [0]], [-3, -4])):
        with pytest.raises(DesignError) as info:
            call()
        assert info.value.parameter == ''
        assert str(info.value) == info.value.reason


def test_config_error_carries_parameter_and_reason():
    error = ConfigError('gain', 'expected 2x1 (2 values, row-major), got 3')
    assert (error.parameter, error.reason) == ('gain', 'expected 2x1 (2 values, row-major), '
                                                       'got 3')
    assert str(error) == 'gain: expected 2x1 (2 values, row-major), got 3'
    assert isinstance(error, ValueError)
    renamed = ConfigError('observer.gain', error.reason)
    assert str(renamed) == 'observer.gain: expected 2x1 (2 values, row-major), got 3'
    assert str(ConfigError('', 'no name')) == 'no name'


def test_design_error_stays_compatible_and_gains_a_parameter():
    plain = DesignError('the pair is not controllable')
    assert (plain.parameter, plain.reason, str(plain)) == (
        '', 'the pair is not controllable', 'the pair is not controllable')
    named = DesignError('requested poles 1 are not stable', parameter='poles')
    assert str(named) == 'poles: requested poles 1 are not stable'
    assert isinstance(named, ValueError)


@pytest.mark.parametrize('error', [ConfigError('gain', 'expected 2x1, got 3'),
                                   DesignError('not stable', parameter='poles'),
                                   DesignError('no single argument')])
def test_errors_survive_pickling(error):
    # Worker processes hand errors back pickled; the fields must come through.
    copy = pickle.loads(pickle.dumps(error))
    assert type(copy) is type(error)
    assert (copy.parameter, copy.reason, str(copy)) == (error.parameter, error.reason,
                                                        str(error))


ROS_NAME = re.compile(r'^(observer|model|plant|feedback|topics)\.[A-Za-z_]')


def _ros_names(path: Path) -> list:
    tree = ast.parse(path.read_text(encoding='utf-8'))
    docstrings = {id(node.body[0].value) for node in ast.walk(tree)
                  if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef))
                  and node.body and isinstance(node.body[0], ast.Expr)}
    return [node.value for node in ast.walk(tree)
            if isinstance(node, ast.Constant) and isinstance(node.value, str)
            and id(node) not in docstrings and ROS_NAME.match(node.value)]


def test_core_modules_speak_in_argument_names():
    offenders = {}
    for path in sorted(CORE.rglob('*.py')):
        relative = path.relative_to(CORE).as_posix()
        names = _ros_names(path)
        if names:
            offenders[relative] = names
    assert not offenders, offenders
