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
What an observer type declares beside its design: its capabilities and its report's items.

:class:`Capabilities` is what the configuration, the nodes and the tools ask of a type
(never its name); :class:`ReportItem` is one field of its design report.
"""

from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class ReportItem:
    """One field of a design report: JSON key, text label and the value (a matrix or number)."""

    key: str
    label: str
    value: Any


@dataclass(frozen=True)
class Capabilities:
    """
    What an observer type can do: the nodes, tools and reports ask these, not its name.

    The defaults are the cautious answers for a type that says nothing.

    Attributes
    ----------
    covariance : bool
        Its estimator carries a covariance: the observer node publishes
        ``x_hat_covariance``, ``innovation_covariance`` and ``nis``, and the diagnostics
        test the NIS against its chi-square band.
    needs_every_output : bool
        Each update needs every output of the model (no update from some of them).
    linear_realization : bool
        Its designs carry an :class:`~observer_ros.core.design.common.ObserverRealization`
        (the observer as a linear system from ``y`` and ``u`` to ``x_hat``): the closed-loop
        analysis (closed-loop poles, ``G_oc``) is made from it; without one it is skipped
        with a note.
    several_sources : bool
        It can take measurements from several sources, each with some of the outputs, at
        their own rates: its estimator offers
        :class:`~observer_ros.core.estimators.SubsetUpdates` (an update from the outputs
        that arrived). A type without it refuses a configuration of several sources.
    angles : bool
        Its estimator keeps angles (``keep_angles``: innovations of angle outputs wrapped,
        angle states kept in ``(-pi, pi]``, :mod:`observer_ros.core.angles`); a type
        without it refuses ``model.angle_states`` and ``model.angle_outputs``.
    needs_observable : bool
        Its design needs every mode seen by the outputs (pole placement). False: only the
        modes that do not decay (a Kalman filter, for which a detectable pair suffices);
        the one observability rule (:func:`~observer_ros.core.analysis.observability_problem`)
        is asked either way.
    equations : bool
        Its estimator runs a model written as equations (``model.dynamics``) itself: the
        configuration's model is then their linearization
        (:class:`~observer_ros.core.nonlinear.linearize.LinearizedModel`) and the estimator
        takes the equations it carries. A type without it is designed on the linearization
        and its gain runs with the nonlinear prediction (:func:`make_estimator`), when its
        step allows it.
    disturbance_arguments : tuple of str
        Its arguments that only apply to a model with ``model.disturbances`` (refused
        without), which the type itself consumes from the disturbance transform it is
        designed with.

    Examples
    --------
    >>> Capabilities().linear_realization
    False

    """

    covariance: bool = False
    needs_every_output: bool = True
    linear_realization: bool = False
    several_sources: bool = False
    needs_observable: bool = True
    angles: bool = False
    disturbance_arguments: tuple = ()
    equations: bool = False
