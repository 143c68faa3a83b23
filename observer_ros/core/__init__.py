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
The ROS-free core: models, analysis, pole placement, designs, estimators and simulation.

``observer_ros.core`` is a flat namespace in the style of python-control: build a model,
check it, design an observer and a state feedback, and run the estimator, all from Python
with no parameter file::

    import observer_ros.core as oc

Names are loaded on first use, so ``import observer_ros.core`` is cheap; python-control is
imported only by the functions that need it (:meth:`StateSpaceModel.from_statespace`,
:meth:`StateSpaceModel.to_statespace`, Varga's placement method). Errors name the function's
own arguments (``gain: expected 2x1 (2 values, row-major), got 3``); see
:mod:`observer_ros.core.errors` for the convention.

Contents
--------
Model
    :class:`StateSpaceModel` (with conversion from and to ``control.StateSpace``),
    :func:`zero_order_hold`, :func:`van_loan`.
Analysis
    :func:`observability`, :func:`controllability`, :class:`RankReport`,
    :func:`observability_matrix`, :func:`controllability_matrix`, :func:`pbh_lost_modes`,
    :func:`require_observable`, :func:`require_controllable`, and the one observability
    rule every design asks: :func:`observability_problem`, :func:`unseen_modes`,
    :class:`UnseenMode`.
Angles
    :class:`Angles`, :func:`check_angles`, :func:`wrap_angles`: outputs and states on a
    circle, wrapped to ``(-pi, pi]`` by every built-in estimator (``keep_angles``).
Poles
    :func:`parse_poles`, :func:`parse_pole`, :func:`damping_pair`, :func:`clean_poles`,
    :func:`sort_poles`, :func:`is_stable`, :func:`to_discrete`,
    :func:`slowest_allowed_pole`, :func:`poles_meeting_error_spec`.
Placement
    :func:`place`, :func:`place_observer`, :class:`PlacementResult`, :data:`METHODS`,
    :func:`placement_residual`.
Designs
    :func:`design_full_order`, :func:`design_reduced_order`, :func:`design_chen`,
    :func:`design_kalman`, :func:`design_sampled_kalman`, :func:`design_feedback` and their
    results (:class:`ObserverDesign`, :class:`ReducedOrderDesign`, :class:`ChenDesign`,
    :class:`KalmanDesign`, :class:`FeedbackDesign`, :class:`ObserverRealization`);
    :func:`full_order_realization`, :func:`predictor_realization`,
    :func:`measured_first_transform`, :func:`reference_gain`.
Observer-controller (the analysis in :mod:`observer_ros.core.loop_analysis`)
    :func:`controller_transfer_function`, :func:`diophantine_controller`,
    :func:`solve_diophantine`, :func:`controller_state_space`, :func:`closed_loop_matrix`,
    :func:`closed_loop_poles`, :class:`ControllerTransferFunction`,
    :class:`UnstableControllerWarning`, :class:`StateFeedbackLaw` (the run-time law,
    :mod:`observer_ros.core.feedback_law`).
Integral action
    :func:`design_integral`, :class:`IntegralDesign`, :func:`augmented_pair`,
    :class:`IntegralAction` (the servo law's integrator, with anti-windup).
Observer types
    :func:`observer_type`, :func:`observer_types`, :class:`ObserverType`,
    :class:`Capabilities`, :func:`register`, :class:`Argument` (what a type reads); each
    type in its package under :mod:`observer_ros.core.observers`, found through the
    entry-point group ``observer_ros.observer_types``.
Estimators
    :func:`make_estimator`, :class:`Estimator` (the protocol), :class:`ConstantGainEstimator`
    (one matrix per interval), :class:`TimeVaryingKalman`, :class:`Prediction`,
    :func:`transition`.
Events
    :class:`EventEngine` (stamped measurements and inputs to rows: the stamp, value and
    pairing rules), :class:`EventStream` (an estimator run on them), :class:`ValueLimits`.
Simulation and evaluation
    :class:`PlantSimulator`, :func:`error_report`, :class:`ErrorReport`,
    :func:`format_error_table`, :func:`settling_time`, :func:`decay_rate`.
Tuning from recordings (:mod:`observer_ros.core.tuning`)
    :func:`autocovariance_least_squares` (``Q`` and ``R`` from innovations),
    :class:`NoiseStructure`, :class:`SampledFilter`, :class:`AlsResult`,
    :func:`innovation_autocovariances`, :class:`InnovationStatistics`, :func:`whiteness`,
    :func:`nis_summary`; :func:`identify_subspace` (PO-MOESP), :class:`Record`,
    :class:`SubspaceModel`, :func:`fit_percent`, :func:`to_continuous`.
Errors
    :class:`ObserverRosError`, :class:`ConfigError`, :class:`DesignError`,
    :class:`UnobservableError`,
    :class:`StampError`.

Examples
--------
A double integrator measured in position, an observer four times faster than the loop:

>>> import numpy as np
>>> import observer_ros.core as oc
>>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
>>> oc.observability(model.a, model.c).full_rank
True
>>> observer = oc.design_full_order(model, poles=[-8, -9])
>>> print(np.round(observer.gain, 6))
[[17.]
 [72.]]
>>> feedback = oc.design_feedback(model, poles=[-2, -2.5])
>>> print(np.round(feedback.gain, 6))
[[5.  4.5]]

Simulate the plant at 100 Hz from ``x = [1, 0]`` and estimate from ``x_hat = [0, 0]``:

>>> plant = oc.PlantSimulator(model, initial_state=[1.0, 0.0])
>>> estimator = oc.make_estimator(observer, initial_state=[0.0, 0.0])
>>> u = np.zeros(1)
>>> for k in range(1, 301):
...     x = plant.step(u, 0.01)
...     x_hat = estimator.update(k * 10_000_000, plant.measure(), u)
>>> bool(np.linalg.norm(x - x_hat) < 1e-6)
True

"""

import importlib

#: Where each public name lives, by module (names are imported on first use).
_EXPORTS = {
    'observer_ros.core.errors': (
        'ObserverRosError', 'ConfigError', 'DesignError', 'UnobservableError', 'StampError'),
    'observer_ros.core.model': ('StateSpaceModel',),
    'observer_ros.core.discretize': ('zero_order_hold', 'van_loan', 'transition'),
    'observer_ros.core.arguments': ('Argument',),
    'observer_ros.core.observers': ('Capabilities', 'ObserverType', 'make_estimator',
                                    'observer_type', 'observer_types', 'register'),
    'observer_ros.core.ranks': (
        'RankReport', 'observability', 'controllability', 'observability_matrix',
        'controllability_matrix', 'pbh_lost_modes', 'require_controllable'),
    'observer_ros.core.analysis': (
        'require_observable', 'observability_problem', 'unseen_modes', 'UnseenMode'),
    'observer_ros.core.angles': ('Angles', 'check_angles', 'wrap_angles'),
    'observer_ros.core.poles': (
        'parse_poles', 'parse_pole', 'damping_pair', 'clean_poles', 'is_stable',
        'to_discrete', 'slowest_allowed_pole', 'poles_meeting_error_spec'),
    'observer_ros.core.placement': ('METHODS', 'PlacementResult', 'place', 'place_observer'),
    'observer_ros.core.placement_checks': ('placement_residual', 'sort_poles'),
    'observer_ros.core.design.common': ('ObserverDesign', 'ObserverRealization',
                                        'predictor_realization'),
    'observer_ros.core.observers.full_order.design': (
        'design_full_order', 'full_order_realization'),
    'observer_ros.core.observers.reduced_order.design': (
        'ReducedOrderDesign', 'design_reduced_order', 'measured_first_transform'),
    'observer_ros.core.observers.chen.design': ('ChenDesign', 'design_chen'),
    'observer_ros.core.observers.kalman.design': (
        'KalmanDesign', 'design_kalman', 'design_sampled_kalman'),
    'observer_ros.core.design.feedback': ('FeedbackDesign', 'design_feedback', 'reference_gain'),
    'observer_ros.core.design.integral': ('IntegralDesign', 'design_integral', 'augmented_pair'),
    'observer_ros.core.loop_analysis.transfer_function': ('ControllerTransferFunction',),
    'observer_ros.core.loop_analysis.observer_controller': (
        'UnstableControllerWarning', 'controller_transfer_function', 'controller_state_space'),
    'observer_ros.core.loop_analysis.diophantine': (
        'diophantine_controller', 'solve_diophantine'),
    'observer_ros.core.loop_analysis.closed_loop': ('closed_loop_matrix', 'closed_loop_poles'),
    'observer_ros.core.feedback_law': ('StateFeedbackLaw', 'IntegralAction'),
    'observer_ros.core.estimators': ('ConstantGainEstimator', 'Estimator', 'Prediction'),
    'observer_ros.core.observers.kalman.time_varying': ('TimeVaryingKalman',),
    'observer_ros.core.events': ('EventEngine',),
    'observer_ros.core.rules': ('ValueLimits',),
    'observer_ros.core.streaming': ('EventStream',),
    'observer_ros.core.simulation': ('PlantSimulator',),
    'observer_ros.core.disturbance_model': ('Disturbance', 'DisturbanceModel',
                                            'augmented_noise'),
    'observer_ros.core.disturbances': ('augment',),
    'observer_ros.core.evaluation': (
        'ErrorReport', 'error_report', 'format_error_table', 'settling_time', 'decay_rate'),
    'observer_ros.core.tuning.noise_model': (
        'NoiseStructure', 'SampledFilter', 'innovation_autocovariances'),
    'observer_ros.core.tuning.als': ('AlsResult', 'autocovariance_least_squares'),
    'observer_ros.core.tuning.innovations': ('InnovationStatistics', 'nis_summary',
                                             'whiteness'),
    'observer_ros.core.tuning.identified_model': (
        'Record', 'SubspaceModel', 'fit_percent', 'to_continuous'),
    'observer_ros.core.tuning.subspace': ('identify_subspace',),
}

_MODULE_OF = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = sorted(_MODULE_OF)


def __getattr__(name: str):
    """Import a public name from its module on first use (PEP 562)."""
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f'module {__name__!r} has no attribute {name!r}')
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list:
    """List the public names with the module's own, for tab completion."""
    return sorted(set(globals()) | set(__all__))
