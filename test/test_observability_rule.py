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
The one observability rule: every observer type, source subset and discretization asks it.

The models below hide an unseen integrator in mixed coordinates: ``A = T diag(0, -1) T^-1``,
only the decaying mode measured and disturbed. Riccati solvers then return a filter whose
unseen pole is ``-1.8e-15`` (continuous) or ``1 - 1e-16`` (discrete), which a refusal
without a margin accepted (``design_observer`` exited 0 and printed the poles
``[0.00888745, 1]``).
"""

import re
import subprocess

import numpy as np
import pytest

from conftest import console_script
from observer_ros.app.design_check import configuration_check
from observer_ros.app.health import ERROR, OK
from observer_ros.config import validate_parameters
from observer_ros.core import (
    ConfigError, design_chen, design_full_order, design_kalman, design_reduced_order,
    design_sampled_kalman, observability_problem, StateSpaceModel, TimeVaryingKalman,
    UnobservableError, unseen_modes)
from observer_ros.core.analysis import boundary_margin, decays, mode_text
from observer_ros.core.discretize import zero_order_hold
from observer_ros.core.estimators import ConstantGainEstimator
from observer_ros.core.observers.kalman.estimator import KalmanStep
from observer_ros.core.sources import check_subsets, MeasurementSource

#: Coordinates that hide the integrator (seeded draws for which the old check passed here).
CONTINUOUS_T = [[1.6, 0.7], [-1.0, -0.2]]
DISCRETE_T = [[1.4, 0.1], [0.3, 0.9]]
NAMES = {'state_names': ['p', 'v'], 'output_names': ['v_meas']}


def hidden_integrator(t, dt=0.0):
    """Return the model, Q and R of an unseen, undisturbed integrator in coordinates ``t``."""
    t = np.array(t)
    t_inv = np.linalg.inv(t)
    a = t @ np.diag([0.0, -1.0]) @ t_inv
    b = t @ np.ones((2, 1))
    c = np.array([[0.0, 1.0]]) @ t_inv
    q = t @ np.diag([0.0, 1.0]) @ t.T
    if dt:
        a, b = zero_order_hold(a, b, dt)
    return StateSpaceModel.from_matrices(a, b, c, dt=dt, **NAMES), q, np.array([[0.01]])


# The unseen direction is T e1: (1.6, -1.0) involves both states, (1.4, 0.3) mostly p.
CASES = [pytest.param(CONTINUOUS_T, 0.0, '0', 'p, v', id='continuous'),
         pytest.param(DISCRETE_T, 0.1, '1', 'p', id='discrete')]


@pytest.mark.parametrize('t, dt, mode, states', CASES)
def test_a_steady_kalman_filter_that_cannot_see_an_integrator_is_refused(t, dt, mode, states):
    model, q, r = hidden_integrator(t, dt)
    with pytest.raises(UnobservableError, match=rf'^\(A, C\) is not detectable: the modes '
                                                rf'{mode} cannot be seen from the outputs '
                                                rf"\['v_meas'\] and do not decay \(mode {mode}: "
                                                rf'states {states};'):
        design_kalman(model, q.ravel(), r.ravel())


@pytest.mark.parametrize('t, dt, mode, states', CASES)
def test_a_time_varying_kalman_filter_that_cannot_see_an_integrator_is_refused(
        t, dt, mode, states):
    model, q, r = hidden_integrator(t, dt)
    with pytest.raises(UnobservableError, match=rf'not detectable: the modes {mode} cannot'):
        TimeVaryingKalman(model, q, r)


def test_every_discretization_asks_the_rule():
    model, q, r = hidden_integrator(CONTINUOUS_T)
    with pytest.raises(UnobservableError, match='not detectable: the modes 1 cannot be seen'):
        design_sampled_kalman(model, q.ravel(), r.ravel(), dt=0.05)
    # A step of another interval, from a filter whose design passed: the rule again.
    seen = StateSpaceModel.from_matrices(model.a, model.b, np.eye(2))
    step = KalmanStep(design_kalman(seen, (q + np.eye(2)).ravel(), [0.01, 0.01]))
    step.model = model
    with pytest.raises(UnobservableError, match='not detectable: the modes 1 cannot be seen'):
        step.design_step(*zero_order_hold(model.a, model.b, 0.02), 0.02)


def test_the_message_names_the_mode_as_the_docs_show_never_its_rounding_noise():
    model, q, r = hidden_integrator(CONTINUOUS_T)
    with pytest.raises(UnobservableError) as info:
        design_kalman(model, q.ravel(), r.ravel())
    assert not re.search(r'\de-\d', str(info.value)), str(info.value)
    assert mode_text(1.72781e-15, 1e-7) == '0'
    assert mode_text(-0.9999999999998) == '-1'
    assert mode_text(0.5 - 2j) == '0.5±2j'
    # A conjugate pair is one mode, named once; its states are the rotating block's.
    a = np.zeros((3, 3))
    a[0, 0] = -1.0
    a[1:, 1:] = [[0.5, 2.0], [-2.0, 0.5]]
    modes = unseen_modes(a, [[1.0, 0.0, 0.0]], state_names=['x', 'p', 'q'])
    assert [(m.text, m.states, m.decays) for m in modes] == [('0.5±2j', ('p', 'q'), False)]


def test_the_rule_has_a_margin_scaled_by_the_model():
    margin = boundary_margin([[0.0, 1.0], [0.0, -1000.0]])
    assert margin == pytest.approx(1e-7 * np.linalg.norm([[0.0, 1.0], [0.0, -1000.0]], 2))
    assert not decays(-3.5e-16, False, margin) and not decays(1 - 1e-16, True, margin)
    assert decays(-1e-3, False, margin) and decays(0.999, True, margin)


def test_an_unseen_mode_that_decays_is_fine_for_a_kalman_filter_only():
    model = StateSpaceModel.from_matrices([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [1.0]],
                                          [[0.0, 1.0]], **NAMES)
    design_kalman(model, [1.0, 1.0], [0.01])
    TimeVaryingKalman(model, np.eye(2), [[0.01]])
    assert observability_problem(model.a, model.c, detectable=True) is None
    for design in (lambda: design_full_order(model, poles=[-3, -4]),
                   lambda: design_reduced_order(model, poles=[-4]),
                   lambda: design_chen(model, poles=[-4])):
        with pytest.raises(UnobservableError, match=r'not observable: the modes -1 cannot be '
                                                    r"seen from the outputs \['v_meas'\] "
                                                    r'\(mode -1: states p;'):
            design()


def test_one_source_alone_and_inside_several_sources_get_the_same_answer():
    # The wheels and the gyro of a differential-drive base cannot see x and yaw.
    a = np.zeros((4, 4))
    a[0, 2] = a[1, 3] = 1.0
    a[2, 2] = a[3, 3] = -5.0
    b = np.vstack([np.zeros((2, 2)), 5.0 * np.eye(2)])
    c = np.array([[0, 0, 10, -2], [0, 0, 10, 2], [0, 0, 0, 1], [1, 0, 0, 0], [0, 1, 0, 0]],
                 dtype=float)
    names = {'state_names': ['x', 'yaw', 'v', 'w'],
             'output_names': ['v_left', 'v_right', 'gyro_z', 'mocap_x', 'mocap_yaw']}
    q = [1e-4, 1e-4, 0.05, 0.05]
    full = StateSpaceModel.from_matrices(a, b, c, **names)
    design = design_kalman(full, q, [0.01, 0.01, 1e-4, 1e-6, 1e-5])
    estimator = ConstantGainEstimator(KalmanStep(design))
    with pytest.raises(Exception, match=r"source 'wheels' \(outputs \['v_left', 'v_right', "
                                        r"'gyro_z'\]\) alone: \(A, C\) of these outputs is not "
                                        r'detectable: the modes 0 cannot be seen from them and '
                                        r'do not decay \(mode 0: states x, yaw;'):
        check_subsets(estimator, [MeasurementSource('wheels', (0, 1, 2)),
                                  MeasurementSource('mocap', (3, 4))], names['output_names'])
    alone = StateSpaceModel.from_matrices(a, b, c[:3], **{
        **names, 'output_names': names['output_names'][:3]})
    with pytest.raises(UnobservableError, match=r'not detectable: the modes 0 cannot be seen '
                                                r"from the outputs \['v_left', 'v_right', "
                                                r"'gyro_z'\] and do not decay \(mode 0: "
                                                r'states x, yaw;'):
        design_kalman(alone, q, [0.01, 0.01, 1e-4])


def hidden_integrator_parameters(time_varying=False):
    model, q, r = hidden_integrator(DISCRETE_T, 0.1)
    return {'model.A': model.a.ravel().tolist(), 'model.B': model.b.ravel().tolist(),
            'model.C': model.c.ravel().tolist(), 'model.dt': 0.1,
            'model.state_names': ['p', 'v'], 'model.output_names': ['v_meas'],
            'observer.type': 'kalman', 'observer.time_varying': time_varying,
            'observer.process_noise': q.ravel().tolist(), 'observer.measurement_noise': [0.01]}


@pytest.mark.parametrize('time_varying', [False, True])
def test_the_configuration_refuses_it_for_both_kalman_filters(time_varying):
    with pytest.raises(ConfigError, match=r'^observer.process_noise: \(A, C\) is not '
                                          r'detectable: the modes 1 cannot be seen'):
        validate_parameters(hidden_integrator_parameters(time_varying))


def test_design_observer_exits_2_naming_the_modes(tmp_path):
    model, q, _ = hidden_integrator(DISCRETE_T, 0.1)

    def floats(values):
        return '[' + ', '.join(repr(float(v)) for v in np.ravel(values)) + ']'

    path = tmp_path / 'unseen.yaml'
    path.write_text(
        '/**:\n  ros__parameters:\n    model:\n'
        f'      A: {floats(model.a)}\n      B: {floats(model.b)}\n      C: {floats(model.c)}\n'
        "      dt: 0.1\n      state_names: ['p', 'v']\n      output_names: ['v_meas']\n"
        "    observer:\n      type: 'kalman'\n"
        f'      process_noise: {floats(q)}\n      measurement_noise: [0.01]\n')
    result = subprocess.run([console_script('design_observer'), str(path)],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2, result.stdout
    assert ('observer.process_noise: (A, C) is not detectable: the modes 1 cannot be seen '
            "from the outputs ['v_meas'] and do not decay (mode 1: states p;") in result.stderr


def test_a_configuration_of_sources_names_the_sources_that_leave_the_mode_unseen():
    wheels_only = {
        'model.A': [0.0, 1.0, 0.0, 0.0], 'model.B': [0.0, 1.0], 'model.C': [0.0, 1.0],
        'model.state_names': ['x', 'v'], 'model.output_names': ['wheel_v'],
        'observer.type': 'kalman', 'observer.time_varying': True,
        'observer.process_noise': [0.0, 1.0], 'observer.sources': ['wheels'],
        'sources.wheels.fields': ['velocity.wheel'], 'sources.wheels.outputs': ['wheel_v'],
        'sources.wheels.measurement_noise': [1e-2]}
    with pytest.raises(ConfigError, match=r"^observer.process_noise: source 'wheels' \(outputs "
                                          r"\['wheel_v'\]\): \(A, C\) is not detectable: the "
                                          r'modes 0 cannot be seen from the outputs '
                                          r"\['wheel_v'\] and do not decay \(mode 0: states x;"):
        validate_parameters(wheels_only)


def test_the_health_check_asks_the_same_rule():
    decaying = StateSpaceModel.from_matrices([[-1.0, 0.0], [0.0, -2.0]], [[1.0], [1.0]],
                                             [[0.0, 1.0]], **NAMES)
    check = configuration_check(decaying, 'kalman', [-3.0, -4.0], detectable=True)
    assert check.level == OK, check.message
    check = configuration_check(decaying, 'full_order', [-3.0, -4.0])
    assert check.level == ERROR and 'the modes -1 cannot be seen' in check.message
    model, _, _ = hidden_integrator(CONTINUOUS_T)
    check = configuration_check(model, 'kalman', [-1.0, -2.0], detectable=True)
    assert check.level == ERROR
    assert 'not detectable: the modes 0 cannot be seen' in check.message
    assert '(mode 0: states p, v;' in check.message
