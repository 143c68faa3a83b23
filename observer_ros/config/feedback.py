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
The state feedback of a configuration: ``feedback.*`` checked and designed.

:func:`feedback_settings` designs ``K`` (or checks a given one) for the plant, with integral
action when asked for, and checks the limits, the safe command and the watchdog's times;
with ``model.disturbances`` the gain on the disturbance estimates comes from the
:class:`~observer_ros.config.model.Augmentation`.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from observer_ros.config.model import Augmentation
from observer_ros.config.sections import FeedbackSection, IntegralSection, ModelSection, Sections
from observer_ros.config.values import check_inside, indices, input_limits
from observer_ros.core.design.feedback import design_feedback, FeedbackDesign
from observer_ros.core.design.integral import design_integral, IntegralDesign
from observer_ros.core.errors import ConfigError
from observer_ros.core.flat_matrices import matrix_from_flat, vector_from_flat
from observer_ros.core.model import StateSpaceModel


@dataclass(frozen=True)
class FeedbackSettings:
    """
    Validated ``feedback.*`` parameters and the feedback design.

    Attributes
    ----------
    design : FeedbackDesign
        ``K`` and its poles (from the integral design with integral action).
    reference_gain : numpy.ndarray or None, shape (m, p)
    input_limits : numpy.ndarray or None, shape (m, 2)
    timeout, safe_command_period : float
        Seconds.
    safe_command : numpy.ndarray, shape (m,)
    disturbance_gain : numpy.ndarray or None, shape (m, n_d)
        ``K_d`` with ``model.disturbances`` (zero unless ``feedback.disturbance_rejection``).
    integral : IntegralDesign or None

    """

    design: FeedbackDesign
    reference_gain: Optional[np.ndarray]
    input_limits: Optional[np.ndarray]
    timeout: float
    safe_command: np.ndarray
    safe_command_period: float
    disturbance_gain: Optional[np.ndarray] = None
    integral: Optional[IntegralDesign] = None

    @property
    def estimate_gain(self) -> np.ndarray:
        """
        Return the gain on the whole estimate: ``[K, K_d]``, ``(m, n + n_d)``.

        ``K_d`` (:attr:`disturbance_gain`) cancels the matched input disturbances when
        ``feedback.disturbance_rejection`` is set and is zero otherwise; without
        disturbances the gain is ``K``.
        """
        if self.disturbance_gain is None:
            return self.design.gain
        return np.hstack([self.design.gain, self.disturbance_gain])

    def pinned_parameters(self) -> dict:
        """
        Return the parameters that pin the design as it is (``design_observer --write``).

        ``{parameter: value}``, None removing the parameter: the gain instead of the poles,
        and the reference gain when there is one.
        """
        binding = FeedbackSection.binding()
        pinned = {binding['gain']: np.ravel(self.design.gain).tolist(), binding['poles']: None}
        if self.reference_gain is not None:
            pinned[binding['reference_gain']] = np.ravel(self.reference_gain).tolist()
        return pinned


def _integral_outputs(section: IntegralSection, model: StateSpaceModel) -> tuple:
    parameter = section.binding()['outputs']
    given = section.outputs
    if given:
        outputs = indices(parameter, given, model.output_names, 'output')
        if len(set(outputs)) != len(outputs):
            raise ConfigError(parameter, f'names an output twice: {given}')
        if len(outputs) > model.n_inputs:
            raise ConfigError(parameter, f'{len(outputs)} integrated outputs need at least as '
                              f'many inputs; the model has m = {model.n_inputs}')
        return outputs
    if model.n_inputs != model.n_outputs:
        raise ConfigError(parameter, f'integral action on a non-square plant (m = '
                          f'{model.n_inputs} inputs, p = {model.n_outputs} outputs) needs the '
                          f'outputs to integrate: name at most {model.n_inputs} of '
                          f'{list(model.output_names)}')
    return tuple(range(model.n_outputs))


def _integral(section: FeedbackSection, model: StateSpaceModel, poles,
              gain) -> Optional[IntegralDesign]:
    """Design the servo gains when integral action is asked for (None otherwise)."""
    integral = section.integral
    own = integral.binding()
    binding = ModelSection.binding() | section.binding() | own
    integral_gain = integral.integral_gain or None
    placed = len(integral.poles) > 0
    if not placed and integral_gain is None:
        if integral.outputs:
            raise ConfigError(own['outputs'], 'integral action needs '
                              'feedback.integral_poles (with feedback.poles) or '
                              'feedback.integral_gain (with feedback.gain)')
        return None
    if placed and integral_gain is not None:
        raise ConfigError(own['integral_gain'], 'give either feedback.integral_gain or '
                          'feedback.integral_poles, not both')
    if integral_gain is not None and gain is None:
        raise ConfigError(own['integral_gain'], 'a given K_i goes with a given '
                          'feedback.gain; with feedback.poles give feedback.integral_poles')
    if placed and gain is not None:
        raise ConfigError(own['poles'], 'the integral poles are placed with '
                          'feedback.poles; with a given feedback.gain give '
                          'feedback.integral_gain')
    outputs = _integral_outputs(integral, model)
    all_poles = None
    if placed:
        integral_poles = integral.poles  # converted once, with the parameters
        if integral_poles.size != len(outputs):
            raise ConfigError(own['poles'], f'expected {len(outputs)} poles (one per '
                              f'integrated output), got {integral_poles.size}')
        all_poles = np.concatenate([poles, integral_poles])
    source = own['integral_gain'] if integral_gain is not None else own['poles']
    with binding.charged(source, numeric=True):
        return design_integral(model, outputs, all_poles, gain, integral_gain, section.method)


def _design(section: FeedbackSection, model: StateSpaceModel,
            integral: Optional[IntegralDesign], poles, gain) -> FeedbackDesign:
    """Return ``K``: from the integral design, or placed (or checked) on its own."""
    if integral is not None:  # K comes from the augmented design; no N by default
        return FeedbackDesign(gain=integral.gain, requested_poles=integral.requested_poles,
                              achieved_poles=integral.achieved_poles, method=integral.method,
                              residual=integral.residual, reference_gain=None)
    binding = ModelSection.binding() | section.binding()
    source = binding['gain'] if gain is not None else binding['poles']
    with binding.charged(source, numeric=True):
        return design_feedback(model, poles, gain, section.method)


def feedback_settings(sections: Sections,
                      augmentation: Augmentation) -> Optional[FeedbackSettings]:
    """
    Check ``feedback.*`` and design the state feedback for the plant (None when not asked).

    Raises
    ------
    ConfigError
        Naming the parameter: a missing or contradictory gain, poles or integral action, a
        failed design, limits or a safe command that do not fit.

    """
    section, model = sections.feedback, augmentation.plant
    binding = ModelSection.binding() | section.binding()
    integral = section.integral
    gain = section.gain or None
    poles = section.poles if len(section.poles) else None  # converted once: a complex array
    if integral.outputs and model.n_inputs == 0:
        raise ConfigError(integral.binding()['outputs'], 'the model has no inputs (model.B is '
                          'empty, m = 0): integral action is not available; leave it empty')
    if gain is None and poles is None:
        _refuse_without_gain(section)
        return None
    if model.n_inputs == 0:
        raise ConfigError(binding['gain'] if gain is not None else binding['poles'],
                          'the model has no inputs (model.B is empty, m = 0): state feedback '
                          'is not available')
    if gain is not None and poles is not None:
        raise ConfigError(binding['gain'], 'give either feedback.gain or feedback.poles, '
                          'not both')
    if poles is not None and poles.size != model.n_states:
        raise ConfigError(binding['poles'],
                          f'expected {model.n_states} poles, got {poles.size}')
    integral_design = _integral(section, model, poles, gain)
    design = _design(section, model, integral_design, poles, gain)
    if section.reference_gain:
        reference_gain = matrix_from_flat(binding['reference_gain'], section.reference_gain,
                                          model.n_inputs, model.n_outputs)
    else:
        reference_gain = design.reference_gain
    limits = input_limits(binding['input_limits'], section.input_limits, model.n_inputs)
    safe_command = (vector_from_flat(binding['safe_command'], section.safe_command,
                                     model.n_inputs) if section.safe_command
                    else np.zeros(model.n_inputs))
    check_inside(binding['safe_command'], safe_command, limits, 'feedback.input_limits')
    check_inside(binding['safe_command'], safe_command, sections.topics['u_cmd'].limit,
                 'topics.u_cmd.limit')
    return FeedbackSettings(
        design=design, reference_gain=reference_gain, input_limits=limits,
        timeout=section.timeout, safe_command=safe_command,
        safe_command_period=section.safe_command_period,
        disturbance_gain=augmentation.disturbance_gain(section.disturbance_rejection),
        integral=integral_design)


def _refuse_without_gain(section: FeedbackSection) -> None:
    """Refuse what needs a feedback gain when none is configured."""
    binding, integral = section.binding(), section.integral
    if section.disturbance_rejection:
        raise ConfigError(binding['disturbance_rejection'], 'expected feedback.gain or '
                          'feedback.poles with it')
    if len(integral.poles) > 0 or len(integral.integral_gain) > 0:
        raise ConfigError(binding['poles'], 'integral action needs the state feedback too: '
                          'feedback.poles or feedback.gain')
    if integral.outputs:
        raise ConfigError(integral.binding()['outputs'], 'integral action needs the state '
                          'feedback (feedback.poles or feedback.gain) and '
                          'feedback.integral_poles or feedback.integral_gain; without them '
                          'leave it empty')
