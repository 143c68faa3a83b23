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
The sections read by name: the topics, topic by topic, and the measurement sources.

:class:`TopicsSection` holds a :class:`TopicSettings` per vector topic and
:class:`SourcesSection` a :class:`SourceSettings` per name of ``observer.sources``, both
read-only mappings made from the checked parameter set.
"""

from dataclasses import dataclass
from typing import Any, Mapping

from observer_ros.config.binding import ReadOnlyMapping
from observer_ros.config.schema import (
    source_parameter, SOURCE_SETTINGS, topic_parameter, TOPIC_ROLES, TOPIC_SETTINGS)
from observer_ros.wire import find


@dataclass(frozen=True)
class TopicSettings:
    """
    ``topics.<topic>.*`` of one vector topic.

    Attributes
    ----------
    type : str
        ``joint_state`` or ``float64_multi_array``.
    field : str
        The JointState field holding the values.
    limit : float
        The largest magnitude a value may have.
    fields : tuple of str
        ``topics.u.fields``: the values read by field path (empty: the vector of ``type``
        and ``field``; other topics have none).

    """

    type: str  # noqa: A003 (the parameter's name)
    field: str
    limit: float
    fields: tuple = ()

    @property
    def stamped(self) -> bool:
        """Whether the messages carry a header stamp (a JointState does): the catalog says."""
        entry = find(self.type)
        return entry is not None and entry.stamped


class SettingsByName(ReadOnlyMapping):
    """A section kept by name (a topic, a source): a read-only mapping of its settings."""


class TopicsSection(SettingsByName):
    """
    ``topics.*``: :class:`TopicSettings` by topic (``topics['y'].limit``), every vector topic.

    Its parameters are :func:`~observer_ros.config.schema.topic_parameter` of each topic of
    :data:`~observer_ros.config.schema.TOPIC_ROLES` and each setting.
    """

    @classmethod
    def parameter_names(cls) -> tuple:
        """Return every ``topics.<topic>.<setting>`` parameter."""
        return tuple(topic_parameter(topic, setting) for topic, _, _ in TOPIC_ROLES
                     for setting in TOPIC_SETTINGS) + (INPUT_FIELDS,)

    @classmethod
    def read(cls, checked: Mapping[str, Any]) -> 'TopicsSection':
        """Return the settings of every vector topic."""
        return cls({topic: TopicSettings(**{
            setting: checked[topic_parameter(topic, setting)] for setting in TOPIC_SETTINGS},
            fields=tuple(checked[INPUT_FIELDS]) if topic == 'u' else ())
            for topic, _, _ in TOPIC_ROLES})


#: ``topics.u.fields``: the inputs read by field path.
INPUT_FIELDS = topic_parameter('u', 'fields')


@dataclass(frozen=True)
class SourceSettings:
    """
    ``sources.<name>.*`` of one measurement source, checked one by one.

    Attributes
    ----------
    name : str
    topic : str
        Its topic (the name when ``sources.<name>.topic`` is empty).
    type : str
        A short name of :data:`~observer_ros.config.schema.FIELD_MESSAGE_TYPES`.
    fields, outputs : tuple of str
        The field paths and the outputs they carry, in the same order.
    measurement_noise : tuple of float
    latency, timeout : float
        Seconds.
    predict_only : bool
    noise : str
        ``configured`` or ``message`` (``R`` from each message's covariance).

    """

    name: str
    topic: str
    type: str  # noqa: A003 (the parameter's name)
    fields: tuple
    outputs: tuple
    measurement_noise: tuple
    latency: float
    timeout: float
    predict_only: bool
    noise: str = 'configured'

    def parameter(self, setting: str) -> str:
        """Return the parameter of one of its settings: ``sources.imu.fields``."""
        return source_parameter(self.name, setting)


class SourcesSection(SettingsByName):
    """
    ``sources.<name>.*``: :class:`SourceSettings` by name, in ``observer.sources`` order.

    Empty without ``observer.sources`` (one source, ``topics.y``). Its parameters are made
    for each name (:func:`~observer_ros.config.schema.source_specs`), so the section binds
    none of the schema's own.
    """

    @classmethod
    def parameter_names(cls) -> tuple:
        """None of the schema's: a source's parameters are made for its name."""
        return ()

    @classmethod
    def read(cls, checked: Mapping[str, Any]) -> 'SourcesSection':
        """Return the settings of every source named in ``observer.sources``."""
        sources = {}
        for name in checked['observer.sources']:
            values = {setting: checked[source_parameter(name, setting)]
                      for setting in SOURCE_SETTINGS}
            for setting in ('fields', 'outputs', 'measurement_noise'):
                values[setting] = tuple(values[setting])
            values['topic'] = values['topic'] or name
            sources[name] = SourceSettings(name, **values)
        return cls(sources)
