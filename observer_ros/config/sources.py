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
The measurement sources of a configuration: ``observer.sources`` and ``sources.<name>.*``.

:func:`measurement_sources` checks what the parameters say of each source (its message
type and field paths, the outputs they carry, its block of ``R``, latency and timeout)
and makes the core's :class:`~observer_ros.core.sources.MeasurementSource` of each.
Without ``observer.sources`` there is one source, ``topics.y``, with every output, as
always. Whether the observer type can update with each source alone is asked when the
stream is made (:meth:`~observer_ros.config.observer.ObserverSetup.make_stream`), which
:func:`~observer_ros.config.validate_parameters` does once at start-up.

The field paths are checked against the wire codec's catalog of message types
(:mod:`observer_ros.wire`, which imports nothing but the standard library and numpy, and
nothing above the configuration), so a wrong path names the path, the type and the fields
it has.
"""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from observer_ros.config.binding import Binding
from observer_ros.config.message_noise import covariance_reader
from observer_ros.config.schema import FIELD_MESSAGE_TYPES
from observer_ros.config.sections import Sections
from observer_ros.config.timing import sample_rate
from observer_ros.config.topic_sections import SourceSettings
from observer_ros.config.values import indices
from observer_ros.core.arguments import number_text
from observer_ros.core.errors import ConfigError
from observer_ros.core.flat_matrices import covariance_from_flat
from observer_ros.core.model import StateSpaceModel
from observer_ros.core.sources import check_sources, MeasurementSource
from observer_ros.core.units import seconds_to_ns
from observer_ros.wire import FieldPathError, FieldReader, find


#: The core's arguments about sources (:func:`~observer_ros.core.sources.check_sources`, the
#: stream), bound to their parameters; a source's own setting is named as its parameter
#: already (``sources.<name>.outputs``).
SOURCE_ARGUMENTS = {'sources': 'observer.sources', 'history': 'observer.history'}


@dataclass(frozen=True)
class SourcesSetup:
    """
    The checked measurement sources: the core's sources and where each is read.

    Attributes
    ----------
    sources : tuple of MeasurementSource
        In ``observer.sources`` order.
    settings : tuple of SourceSettings
        Their parameters (topic, message type, fields), in the same order.
    msgtypes : tuple of str
        The full message type of each (``sensor_msgs/msg/Imu``).
    measurement_noise : numpy.ndarray or None
        ``R`` made of the sources' blocks (None when they give none).

    """

    sources: tuple
    settings: tuple
    msgtypes: tuple
    measurement_noise: Optional[np.ndarray] = None


def _source(settings: SourceSettings, model: StateSpaceModel) -> MeasurementSource:
    """Check one source's own settings; return its MeasurementSource."""
    msgtype = FIELD_MESSAGE_TYPES[settings.type]
    fields = settings.parameter('fields')
    if not settings.fields:
        raise ConfigError(fields, 'expected at least one field path (for example '
                          'angular_velocity.z), got none')
    try:
        FieldReader(msgtype, settings.fields)
    except FieldPathError as e:
        raise ConfigError(fields, str(e)) from None
    outputs = settings.parameter('outputs')
    if len(settings.outputs) != len(settings.fields):
        raise ConfigError(outputs, f'expected {len(settings.fields)} outputs (one per field '
                          f'of {fields}), got {len(settings.outputs)}')
    carried = indices(outputs, settings.outputs, model.output_names, 'output')
    if settings.noise == 'message':  # the type and each field must have a covariance
        covariance_reader(settings.parameter('noise'), msgtype, settings.fields)
    return MeasurementSource(settings.name, carried, seconds_to_ns(settings.latency),
                             seconds_to_ns(settings.timeout), settings.predict_only)


def _noise_blocks(sources: tuple, settings: tuple, model: StateSpaceModel) -> Optional[
        np.ndarray]:
    """Return ``R`` of the sources' ``measurement_noise`` blocks (None when none gives one)."""
    given = [item for item in settings if item.measurement_noise]
    if not given:
        return None
    if len(given) != len(settings):
        missing = [item.parameter('measurement_noise') for item in settings
                   if not item.measurement_noise]
        raise ConfigError(missing[0], f'expected the block of R of every source once one '
                          f'source gives its own ({given[0].parameter("measurement_noise")}); '
                          f'got none')
    noise = np.zeros((model.n_outputs, model.n_outputs))
    for source, item in zip(sources, settings):
        block = covariance_from_flat(item.parameter('measurement_noise'),
                                     item.measurement_noise, len(source.outputs))
        noise[np.ix_(source.outputs, source.outputs)] = block
    return noise


def measurement_sources(sections: Sections, model: StateSpaceModel) -> Optional[SourcesSetup]:
    """
    Check ``observer.sources`` and ``sources.<name>.*``; None without sources.

    Raises
    ------
    ConfigError
        Naming the parameter: a wrong field path (with the type and the fields it has),
        outputs that are no outputs of the model, of the wrong count, a block of R of the
        wrong size or given for some sources only, a timeout not above one sample period.
        The rules between the sources (each output in exactly one source, named by
        ``sources.<name>.outputs`` or ``observer.sources``; a latency longer than
        ``observer.history``) are the core's
        :func:`~observer_ros.core.sources.check_sources`, the one place of them, asked
        here before the design and again by the stream, which
        :func:`~observer_ros.config.validate_parameters` builds once.

    """
    settings = tuple(sections.sources.values())
    if not settings:
        return None
    history_ns = seconds_to_ns(sections.observer.history, SOURCE_ARGUMENTS['history'])
    with Binding(SOURCE_ARGUMENTS).charged(SOURCE_ARGUMENTS['sources']):
        sources = check_sources(tuple(_source(item, model) for item in settings),
                                model.n_outputs, history_ns, model.output_names)
    rate, rate_source = sample_rate(sections, model)
    for item in settings:
        if item.timeout and item.timeout * rate <= 1.0:
            raise ConfigError(item.parameter('timeout'), f'expected 0 (never stale) or more '
                              f'than one sample period ({number_text(1.0 / rate)} s at '
                              f'{number_text(rate)} Hz, from {rate_source}), got '
                              f'{number_text(item.timeout)}')
    return SourcesSetup(sources, settings,
                        tuple(FIELD_MESSAGE_TYPES[item.type] for item in settings),
                        _noise_blocks(sources, settings, model))


def check_input_fields(sections: Sections, model: StateSpaceModel) -> None:
    """
    Check ``topics.u.fields``: one valid field path of ``topics.u.type`` per input.

    Raises
    ------
    ConfigError
        ``topics.u.fields``: missing for ``twist``, of the wrong count, or a path the type
        does not have (naming the path, the type and the fields it has).

    """
    settings = sections.topics['u']
    parameter = 'topics.u.fields'
    if not settings.fields:
        entry = find(settings.type)
        if entry is not None and not entry.vector:  # read by field path alone
            raise ConfigError(parameter, f'expected the {model.n_inputs} fields of '
                              f'topics.u.type {settings.type} that hold the inputs '
                              f'{list(model.input_names)} (for example linear.x, angular.z), '
                              f'got none')
        return
    if len(settings.fields) != model.n_inputs:
        raise ConfigError(parameter, f'expected {model.n_inputs} fields (one per input '
                          f'{list(model.input_names)}), got {len(settings.fields)}')
    try:
        FieldReader(FIELD_MESSAGE_TYPES[settings.type], settings.fields)
    except FieldPathError as e:
        raise ConfigError(parameter, str(e)) from None
