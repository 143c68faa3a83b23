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
The one function that validates a parameter set, and the :class:`Configuration` it makes.

:func:`validate_parameters` turns a flat ``{'model.A': [...], ...}`` mapping into a
:class:`Configuration`, or raises ConfigError naming the parameter. It has no side
effects, so the nodes vet run-time changes with it before they apply them, and the design
CLI and the bag tools read files with it. A node validates what it uses
(``validate_parameters(params, node=OBSERVER)``, :data:`NODE_PARTS`): the plant simulator
designs no observer.
"""

from dataclasses import dataclass, field
from typing import Any, Mapping, Optional

from observer_ros.config.feedback import feedback_settings, FeedbackSettings
from observer_ros.config.loop import analyse_loop, LoopAnalysis
from observer_ros.config.model import Augmentation
from observer_ros.config.node_specs import node_parts
from observer_ros.config.observer import observer_design, ObserverSetup
from observer_ros.config.plant import plant_settings, PlantSettings
from observer_ros.config.sections import DiagnosticsSection, Sections
from observer_ros.config.sources import check_input_fields
from observer_ros.config.timing import check_sample_period, sample_rate
from observer_ros.config.topic_sections import TopicsSection
from observer_ros.core.errors import ConfigError
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.streaming import EventStream

#: The parts of a configuration: what each section becomes.
PARTS = ('observer', 'feedback', 'plant')

#: The parts each node builds from its sections (every node also has the model, the
#: topics and the diagnostics), from its spec (:mod:`observer_ros.config.node_specs`). A
#: node that runs an observer and a feedback law lists both (and then also gets the loop
#: analysis); the CLI and the bag tools build every part.
NODE_PARTS = node_parts()


@dataclass(frozen=True)
class Configuration:
    """
    Everything a validated parameter set defines, as the code uses it.

    Attributes
    ----------
    sections : Sections
        The parameters, checked, as typed sections (``sections.plant.samples``).
    augmentation : Augmentation
        The plant and the model made from it by ``model.disturbances``.
    sample_rate_hz : float
        The rate the inputs are expected at (``diagnostics.expected_rate``, else the
        plant's).
    observer : ObserverSetup or None
        None when the parameters define no observer (no poles, gain or noise), or the node
        does not run one.
    feedback : FeedbackSettings or None
        None without ``feedback.gain`` or ``feedback.poles``, or when the node does not
        run the feedback.
    plant : PlantSettings or None
        None when the node does not simulate the plant.
    loop : LoopAnalysis
        The closed loop of observer and feedback (empty unless both are built).

    """

    sections: Sections
    augmentation: Augmentation
    sample_rate_hz: float
    observer: Optional[ObserverSetup] = None
    feedback: Optional[FeedbackSettings] = None
    plant: Optional[PlantSettings] = None
    loop: LoopAnalysis = field(default_factory=LoopAnalysis)

    @property
    def model(self) -> StateSpaceModel:
        """
        The model the observer estimates and the plant simulates.

        The plant augmented with the disturbance states (plant states first) with
        ``model.disturbances``, else the plant itself (:attr:`augmentation`).
        """
        return self.augmentation.model

    @property
    def topics(self) -> TopicsSection:
        """``topics.*``: the settings of each vector topic."""
        return self.sections.topics

    @property
    def diagnostics(self) -> DiagnosticsSection:
        """``diagnostics.*``."""
        return self.sections.diagnostics

    @property
    def parameters(self) -> dict:
        """The complete checked parameter mapping, for writing a parameter file."""
        return self.sections.parameters

    def required_observer(self, user: str) -> ObserverSetup:
        """
        Return the observer's setup, which ``user`` (``'replay'``) cannot do without.

        The one place of the rule that a user of the observer needs one configured: the
        stream, the bag replay and the observer node ask it.

        Raises
        ------
        ConfigError
            ``observer.poles``: no observer is configured, naming ``user``.

        """
        if self.observer is None:
            raise ConfigError('observer.poles', f'no observer is configured: {user} needs '
                              f'observer.poles, observer.gain or the Kalman noise '
                              f'covariances')
        return self.observer

    def make_stream(self) -> EventStream:
        """
        Build the observer's :class:`EventStream` (:meth:`ObserverSetup.make_stream`).

        Raises
        ------
        ConfigError
            ``observer.poles``: no observer is configured (:meth:`required_observer`).

        """
        return self.required_observer('the stream').make_stream()


def validate_parameters(params: Mapping[str, Any], strict: bool = False,
                        node: Optional[str] = None) -> Configuration:
    """
    Validate a flat parameter mapping and build what it defines.

    Parameters
    ----------
    params : mapping
        ``{'model.A': [...], 'observer.poles': ['-8', '-9'], ...}``; missing names take their
        defaults from the schema (:data:`observer_ros.config.schema.PARAMETERS`).
    strict : bool
        Reject names outside the schema (besides ROS's own).
    node : str, optional
        Build only the parts this node uses (:data:`NODE_PARTS`); default: every part and
        the loop analysis (the design CLI, the bag tools).

    Returns
    -------
    Configuration

    Raises
    ------
    ConfigError
        The message starts with the parameter name and says what was expected. Design
        failures (unobservable pair, unstable given gain...) are reported against the
        parameter that caused them.

    """
    parts = PARTS if node is None else NODE_PARTS[node]
    sections = Sections.check(params, strict)
    augmentation = Augmentation.read(sections.model)
    model = augmentation.model
    observer = observer_design(sections, augmentation) if 'observer' in parts else None
    feedback = feedback_settings(sections, augmentation) if 'feedback' in parts else None
    plant = plant_settings(sections, augmentation) if 'plant' in parts else None
    check_sample_period(sections, model, params)
    check_input_fields(sections, model)
    if observer is not None and observer.checks_sources:
        observer.check_stream()  # built once, at start-up: ObserverSetup.take_stream hands it on
    return Configuration(sections, augmentation, sample_rate(sections, model)[0], observer,
                         feedback, plant, analyse_loop(augmentation, observer, feedback))
