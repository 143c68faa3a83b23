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
The configuration status of a node: its validated design judged, without ROS.

:func:`configuration_check` says what the node runs (the model's sizes, the observer type,
the achieved observer, feedback and closed-loop poles) and flags what cannot work: a mode
no output sees (the one observability rule,
:func:`~observer_ros.core.analysis.observability_problem`), an observer or a closed loop on
or beyond the stability boundary, and the validation's own warnings. It is a
:class:`~observer_ros.app.health.Check` like the run-time checks of
:mod:`observer_ros.app.health`.
"""

from typing import Optional, Sequence

import numpy as np

from observer_ros.app.health import Check, combine, ERROR, WARN
from observer_ros.core.analysis import observability_problem
from observer_ros.core.ranks import format_modes, observability


def poles_text(poles) -> str:
    """Format poles for a value: ``-3+3j, -3-3j`` (``none`` when there are none)."""
    if poles is None or len(poles) == 0:
        return 'none'
    return format_modes(poles)


def unstable(poles, discrete: bool) -> bool:
    """Whether a pole lies on or beyond the stability boundary."""
    poles = np.asarray(poles, dtype=complex)
    if discrete:
        return bool(np.any(np.abs(poles) >= 1.0))
    return bool(np.any(poles.real >= 0.0))


def configuration_check(model, observer_kind: Optional[str], observer_poles,
                        feedback_poles=None, closed_loop_poles=None,
                        notes: Sequence[str] = (), extra: Sequence[tuple] = (),
                        detectable: bool = False) -> Check:
    """
    Return the configuration status of a node's validated design.

    Parameters
    ----------
    model : StateSpaceModel
    observer_kind : str or None
        ``observer.type`` (None for a node without an observer).
    observer_poles : array_like or None
        Achieved observer poles.
    feedback_poles : array_like or None
        Achieved poles of ``A - B K``.
    closed_loop_poles : array_like or None
        Poles of the observer-based closed loop.
    notes : sequence of str
        Warnings of the validation (an unstable controller): each is a :data:`WARN`.
    extra : sequence of (str, object)
        More values to show.
    detectable : bool
        The observer needs only the modes that do not decay seen (its type's capability
        ``needs_observable`` is false: a Kalman filter); the one observability rule decides.

    """
    report = observability(model.a, model.c)
    discrete = model.is_discrete
    values = [('model', f'n={model.n_states} m={model.n_inputs} p={model.n_outputs} '
               + (f'dt={model.dt:g} s' if discrete else 'continuous')),
              ('observable', str(report.full_rank).lower()),
              ('observability_rank', f'{report.rank}/{model.n_states}')]
    findings = [(WARN, note) for note in notes]
    if observer_kind is not None:
        values += [('observer_type', observer_kind),
                   ('observer_poles', poles_text(observer_poles))]
        problem = observability_problem(model.a, model.c, detectable=detectable,
                                        discrete=discrete,
                                        state_names=model.state_names or None)
        if problem is not None:
            findings.append((ERROR, problem))
        if observer_poles is not None and len(observer_poles) and unstable(observer_poles,
                                                                           discrete):
            findings.append((ERROR, 'the observer is unstable: a pole is on or beyond the '
                             'stability boundary'))
    if feedback_poles is not None:
        values.append(('feedback_poles', poles_text(feedback_poles)))
    if closed_loop_poles is not None:
        values.append(('closed_loop_poles', poles_text(closed_loop_poles)))
        if len(closed_loop_poles) and unstable(closed_loop_poles, discrete):
            findings.append((ERROR, 'the closed loop is unstable'))
    values += list(extra)
    return combine('configuration', findings, values)


__all__ = ['configuration_check', 'poles_text', 'unstable']
