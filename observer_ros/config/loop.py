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
The closed loop of a configuration's observer and state feedback, and its notes.

:func:`analyse_loop` computes the closed-loop poles and, for a single-input single-output
plant, the observer-controller ``G_oc`` (:mod:`observer_ros.core.loop_analysis`), when the
observer has a linear realization; otherwise it says why not in a note.
"""

from dataclasses import dataclass, field
from typing import Optional
import warnings

import numpy as np

from observer_ros.config.feedback import FeedbackSettings
from observer_ros.config.model import Augmentation
from observer_ros.config.observer import ObserverSetup
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.loop_analysis.closed_loop import closed_loop_poles
from observer_ros.core.loop_analysis.observer_controller import controller_transfer_function
from observer_ros.core.loop_analysis.transfer_function import ControllerTransferFunction


@dataclass(frozen=True)
class LoopAnalysis:
    """
    The closed loop of observer and state feedback.

    Attributes
    ----------
    closed_loop_poles : numpy.ndarray or None
        The poles of plant, observer and feedback together (None without both, or without
        a linear realization of the observer).
    controller_tf : ControllerTransferFunction or None
        ``G_oc`` of a single-input single-output plant.
    notes : tuple of str
        Warnings worth showing (an unstable controller, an analysis skipped).

    """

    closed_loop_poles: Optional[np.ndarray] = None
    controller_tf: Optional[ControllerTransferFunction] = None
    notes: tuple = field(default_factory=tuple)


def analyse_loop(augmentation: Augmentation, observer: Optional[ObserverSetup],
                 feedback: Optional[FeedbackSettings]) -> LoopAnalysis:
    """
    Analyse the loop of ``observer`` and ``feedback`` on the model (empty without both).

    With integral action the poles are the servo loop's and the observer's (separation);
    with ``model.disturbances`` the generators' modes are dropped (see
    :class:`~observer_ros.config.model.Augmentation`).

    Raises
    ------
    ConfigError
        ``observer.poles`` (or ``observer.poles / observer.gain``): ``G_oc`` would be
        numerically unreliable.

    """
    if observer is None or feedback is None:
        return LoopAnalysis()
    model, design = augmentation.model, observer.design
    if not observer.kind.capabilities.linear_realization:
        return LoopAnalysis(notes=(
            f'closed-loop analysis skipped: the {observer.kind.name} observer has no linear '
            f'realization, so neither the closed-loop poles nor G_oc are defined',))
    if feedback.integral is not None:
        # Separation: the servo loop's poles (on the augmented model) and the observer's.
        return LoopAnalysis(
            np.concatenate([feedback.integral.achieved_poles, design.achieved_poles]),
            notes=('integral action: no single observer-controller transfer function is '
                   'given (the integrator takes the measured y)',))
    poles = augmentation.loop_poles(
        closed_loop_poles(model, design.realization, feedback.estimate_gain))
    if model.n_inputs != 1 or model.n_outputs != 1:
        return LoopAnalysis(poles)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter('always')
        try:
            controller_tf = controller_transfer_function(
                model, design.realization, feedback.estimate_gain, augmentation.cross_check)
        except DesignError as e:
            # The realization comes from the poles and, when given, the gain.
            binding = observer.binding
            culprit = (f'{binding["poles"]} / {binding["gain"]}'
                       if observer.arguments.get('gain') else binding['poles'])
            raise ConfigError(culprit, e.reason) from e
    return LoopAnalysis(poles, controller_tf, tuple(str(w.message) for w in caught))
