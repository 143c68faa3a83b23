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
Offline replay: the configured observer over a bag's ``y`` and ``u``, with recorded stamps.

The estimates come from :meth:`observer_ros.core.streaming.EventStream.replay`: the
observer node's event engine (pairing, stamp and value rules) and estimator arithmetic, so
they equal what the node publishes for the same messages, bit for bit. Use :func:`replay_bag`
from your own tests::

    from observer_ros.bags.replay import replay_bag
    result = replay_bag('my_run', 'my_params.yaml')
    assert result.error_norms()[-1] < 1e-3  # against /x_true; or any check on the arrays

The results are :mod:`observer_ros.bags.replay_results`, what is read
:mod:`observer_ros.bags.replay_reading`, the time-base checks :mod:`observer_ros.bags.time_bases`;
writing the results to a bag or a CSV file is :mod:`observer_ros.bags.replay_outputs`.
"""

import dataclasses
import os
from typing import Optional, Union

import numpy as np

from observer_ros.bags.reading import read_topics
from observer_ros.bags.replay_reading import recorded_events, topic_request
from observer_ros.bags.replay_results import InOrderEstimates, ReplayResult
from observer_ros.bags.storage import absolute_topic, TopicData
from observer_ros.bags.time_bases import check_time_bases, log_timed, stream_warnings
from observer_ros.config import Configuration, load_parameter_file, validate_parameters
from observer_ros.core.estimates import replay_arrays
from observer_ros.core.events import INPUT, MEASUREMENT
from observer_ros.core.streaming import next_measurement_stamps


#: What made each published estimate (``ReplayResult.events``): a measurement source's
#: name (``y`` without sources) for its own estimate, and these.
RERUN, INPUT_EVENT, FLUSHED = 'rerun', 'input', 'flush'

#: A replay reads every message's covariance before it runs: its blocks are all kept.
NO_PRUNING = 1 << 62


def replay_data(bag, system: Configuration, outputs: TopicData, inputs: TopicData,
                use_log_time: bool = False, y_topic: str = 'y', u_topic: str = 'u',
                log_time_advice: str = '') -> 'ReplayResult':
    """
    Run the observer of ``system`` over measurements and inputs already read from ``bag``.

    What :func:`replay_bag` does without measurement sources (its second half), and what
    readers of other topics run:
    ``tune_kalman --inputs/--outputs`` reads them by field path
    (:func:`observer_ros.bags.signals.read_signals`). The stamps are checked for one time
    base (:func:`~observer_ros.bags.time_bases.check_time_bases`, its advice
    ``log_time_advice`` when given) unless ``use_log_time``, which stamps both with their
    log times.
    """
    setup = system.observer
    max_gap_ns, input_stamped = setup.max_gap_ns, setup.input_stamped
    if use_log_time:
        outputs, inputs, input_stamped = log_timed(outputs), log_timed(inputs), False
    else:
        check_time_bases(outputs, inputs, max_gap_ns, str(bag), absolute_topic(y_topic),
                         absolute_topic(u_topic), *([log_time_advice] if log_time_advice
                                                    else []))
    if setup.unstamped_input == 'next_measurement' and not input_stamped:
        # As the node holds each unstamped u for the next measurement (hold_input).
        kept, stamps = next_measurement_stamps(inputs.log_times_ns, outputs.log_times_ns,
                                               outputs.stamps_ns)
        inputs = TopicData(stamps, inputs.log_times_ns[kept], inputs.values[kept])
    stream = setup.make_stream()
    stream.input_stamped = input_stamped
    stream.engine.retired = []
    result = stream.replay(inputs.stamps_ns, inputs.values, outputs.stamps_ns, outputs.values,
                           inputs.log_times_ns, outputs.log_times_ns)
    labels = _stamp_events(result.stamps_ns)
    return ReplayResult(system, str(bag), result.stamps_ns, result.estimates,
                        result.innovations, outputs, inputs, dict(stream.counters),
                        use_log_time, result.covariances, result.innovation_covariances,
                        result.nis, stream_warnings(stream, str(bag), y_topic, u_topic),
                        labels, _in_order(stream, result, labels))


def load_system(parameters: Union[str, os.PathLike, Configuration]) -> Configuration:
    """
    Return the validated system of a parameter file (or ``parameters`` itself).

    Raises
    ------
    observer_ros.core.errors.ConfigError
        A bad parameter file, or one without an observer, naming the parameter; an
        unknown parameter is an error, as in ``design_observer``.

    """
    system = parameters if isinstance(parameters, Configuration) else validate_parameters(
        load_parameter_file(str(parameters)), strict=True)
    system.required_observer('replay')
    return system


def _replay_sources(bag, system: Configuration, y_topic: str, u_topic: str,
                    use_log_time: bool) -> 'ReplayResult':
    """:func:`replay_bag` message by message: measurement sources, or inputs by field."""
    stream = system.observer.make_stream()
    noise = getattr(stream.estimator, 'message_noise', None)  # noise: message, every block
    if noise is not None:
        noise.keep_ns = NO_PRUNING
    events, counts = recorded_events(bag, system, u_topic, use_log_time, y_topic,
                                     None if noise is None else noise.take)
    if use_log_time:
        stream.input_stamped = False
    if system.observer.unstamped_input == 'next_measurement' and not stream.input_stamped:
        events = _held_inputs(events)
    stream.engine.retired = []
    causes: list = []
    samples = stream.replay_events(events, causes)
    model = system.model
    arrays = replay_arrays([sample._replace(innovation=_full_innovation(sample, model),
                                            innovation_covariance=None, nis=None)
                            for sample in samples], model.n_states, model.n_outputs)
    labels = _cause_events(samples, causes, stream.engine.sources)
    arrays = dataclasses.replace(arrays, covariances=_covariances(samples, model.n_states))
    measured = [event for event in events if event.source != INPUT]
    inputs = [event for event in events if event.source == INPUT]
    counters = dict(stream.counters)
    counters['malformed'] = counters.get('malformed', 0) + sum(
        count['malformed'] for count in counts.values())
    return ReplayResult(system, str(bag), arrays.stamps_ns, arrays.estimates,
                        arrays.innovations, _topic_data(measured, 0), _topic_data(
                            inputs, model.n_inputs), counters, use_log_time,
                        arrays.covariances, None, None,
                        stream_warnings(stream, str(bag), y_topic, u_topic), labels,
                        _in_order(stream, arrays, labels))


def _held_inputs(events: list) -> list:
    """Stamp each unstamped input with the next measurement in bag order (hold_input's rule)."""
    order = np.arange(len(events))
    is_input = np.array([event.source == INPUT for event in events], dtype=bool)
    measured = order[~is_input]
    kept, stamps = next_measurement_stamps(order[is_input], measured,
                                           [events[i].stamp_ns for i in measured])
    held = dict(zip(order[is_input][kept].tolist(), stamps.tolist()))
    return [event._replace(stamp_ns=held[index]) if index in held else event
            for index, event in enumerate(events) if event.source != INPUT or index in held]


def _covariances(samples: list, n_states: int) -> Optional[np.ndarray]:
    """
    Return ``P`` of each sample, ``(k, n, n)``: NaN where a sample has none, None if none has.

    The first estimate of a steady-state filter has no covariance yet (the node publishes
    none for it); the rest still go to the CSV.
    """
    if not any(sample.covariance is not None for sample in samples):
        return None
    missing = np.full((n_states, n_states), np.nan)
    return np.array([missing if sample.covariance is None else sample.covariance
                     for sample in samples], dtype=float)


def _in_order(stream, published, events) -> 'InOrderEstimates':
    """
    Return the in-order estimates of a replayed stream, after every late sample.

    With a history: the entries that left it (final) and those still in it, oldest first,
    each named by the sources of its update (``wheels+imu``). Without one nothing is re-run
    and the published estimates are the in-order ones.
    """
    engine = stream.engine
    if not engine.keeps_history:
        return InOrderEstimates(published.stamps_ns, published.estimates,
                                published.covariances, np.asarray(events, dtype=str))
    entries = [entry for entry in (engine.retired or []) + list(engine.entries)
               if entry.result is not None]
    n_states = stream.estimator.n_states
    stamps = np.array([entry.stamp_ns for entry in entries], dtype=np.int64)
    estimates = np.array([entry.result.estimate for entry in entries],
                         dtype=float).reshape(-1, n_states)
    covariances = _covariances([entry.result for entry in entries], n_states)
    names = np.array(['+'.join(entry.parts) for entry in entries], dtype=str)
    return InOrderEstimates(stamps, estimates, covariances, names)


def _full_innovation(sample, model) -> np.ndarray:
    """Return the innovation as a p-vector: NaN where an output was not in the update."""
    outputs = getattr(sample, 'outputs', None)
    if outputs is None:
        return sample.innovation
    full = np.full(model.n_outputs, np.nan)
    full[list(outputs)] = sample.innovation
    return full


def _topic_data(events: list, width: int) -> TopicData:
    """Return the events read as TopicData (values only when they share one width)."""
    stamps = np.array([event.stamp_ns for event in events], dtype=np.int64)
    logged = np.array([event.arrival_ns for event in events], dtype=np.int64)
    values = (np.array([event.values for event in events]).reshape(len(events), width)
              if width else np.zeros((len(events), 0)))
    return TopicData(stamps, logged, values)


def replay_bag(bag: Union[str, os.PathLike],
               parameters: Union[str, os.PathLike, Configuration],
               y_topic: str = 'y', u_topic: str = 'u',
               use_log_time: bool = False) -> ReplayResult:
    """
    Run the configured observer over a bag.

    Parameters
    ----------
    bag : path-like
        rosbag2 directory (MCAP or sqlite3), or one storage file.
    parameters : path-like or Configuration
        Parameter file (``/**: ros__parameters:``) or an already validated system. Its
        ``topics.y.*`` and ``topics.u.*`` give the message types, fields and joint names;
        with ``observer.sources`` each source's topic is read by its fields and every
        message goes to the stream in bag order
        (:func:`~observer_ros.bags.replay_reading.recorded_events`,
        :meth:`~observer_ros.core.streaming.EventStream.replay_events`), as the node takes
        them from ``play_bag``. Its innovations are then NaN where an output was not in the
        update, and it has no innovation covariances or NIS.
    y_topic, u_topic : str
        Topic names in the bag (``y`` is ``/y``; a bag's ``y`` recorded without the slash
        is found either way). A model without inputs (m = 0) reads no ``u_topic``.
    use_log_time : bool
        Stamp ``y`` and ``u`` (and the truth) with their log times, the recorder's clock,
        instead of their header stamps: for bags whose streams are stamped in different
        time bases (see :func:`~observer_ros.bags.time_bases.check_time_bases`).

    Raises
    ------
    observer_ros.bags.storage.BagError
        The bag cannot give the topics (see :func:`observer_ros.bags.reading.read_topic`),
        or they are stamped in different time bases.
    observer_ros.core.errors.ConfigError
        A bad parameter file, naming the parameter.

    """
    system = load_system(parameters)
    if system.observer.sources is not None or system.topics['u'].fields:
        return _replay_sources(bag, system, y_topic, u_topic, use_log_time)
    if system.model.n_inputs == 0:  # no inputs: the measurements alone
        (outputs,) = read_topics(bag, [topic_request(system, 'y', y_topic)])
        inputs = TopicData(np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros((0, 0)))
    else:
        outputs, inputs = read_topics(bag, [topic_request(system, 'y', y_topic),
                                            topic_request(system, 'u', u_topic)])
    return replay_data(bag, system, outputs, inputs, use_log_time, y_topic, u_topic)


def _cause_events(samples: list, causes: list, sources: dict) -> np.ndarray:
    """
    Name what made each estimate of :meth:`EventStream.replay_events`.

    The source of the measurement it is the estimate of (at the measurement's stamp, less
    the source's latency), ``rerun`` for the newest estimate corrected after a late sample,
    ``input`` for estimates an input released, ``flush`` for those of the final flush.
    """
    labels = []
    for sample, event in zip(samples, causes):
        if event is None:
            labels.append(FLUSHED)
        elif event.source == INPUT:
            labels.append(INPUT_EVENT)
        elif sample.stamp_ns == event.stamp_ns - sources[event.source].latency_ns:
            labels.append(event.source)
        else:
            labels.append(RERUN)
    return np.array(labels, dtype=str)


def _stamp_events(stamps_ns: np.ndarray) -> np.ndarray:
    """Name the estimates of one ``y`` stream: ``y``, or ``rerun`` at a stamp given before."""
    _, first = np.unique(stamps_ns, return_index=True)
    labels = np.full(len(stamps_ns), RERUN, dtype=object)
    labels[first] = MEASUREMENT
    return labels.astype(str)
