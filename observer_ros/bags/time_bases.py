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
Time bases of a recording: refuse ``y`` and ``u`` stamped in different clocks, warn as a node.

:func:`check_time_bases` is the up-front check of a replay (and of ``tune_kalman``'s
paired signals); :func:`stream_warnings` says after a replay what the observer node would
have warned of; :func:`log_timed` restamps a stream with its log times, the way out.
"""

import numpy as np

from observer_ros.bags.storage import absolute_topic, BagError, TopicData
from observer_ros.core.units import NANOSECONDS


#: Inputs, evenly spread, whose stamps are compared with the measurements' time base.
TIME_BASE_SAMPLES = 4096


#: What to do about streams stamped in different time bases, offline.
LOG_TIME_ADVICE = ('replay with log times for both (replay --use-log-time, '
                   'replay_bag(..., use_log_time=True))')


#: Event kinds of the stream that a replay reports as warnings (the node warns of them too).
WARNED_EVENTS = ('time_base',)


def log_timed(data: TopicData) -> TopicData:
    """Return ``data`` stamped with its log times (the recorder's clock) instead."""
    return TopicData(data.log_times_ns, data.log_times_ns, data.values)


def _seconds(ns: float) -> str:
    return f'{ns / NANOSECONDS:.6g} s'


def _clock(data: TopicData) -> str:
    """Say how a stream's stamps relate to its log times, for the time-base message."""
    offsets = data.stamps_ns - data.log_times_ns
    if not offsets.any():
        return 'uses its log times (unstamped, or stamped on arrival)'
    return f'has header stamps {_seconds(float(np.median(offsets)))} from its log times'


def check_time_bases(outputs: TopicData, inputs: TopicData, max_gap_ns: int, bag: str = '',
                     y_topic: str = 'y', u_topic: str = 'u',
                     log_time_advice: str = LOG_TIME_ADVICE) -> None:
    """
    Refuse measurements and inputs stamped in different time bases.

    A ``y`` stamped in simulation time (header stamps near 0 s) with an unstamped ``u``
    that falls back to the recorder's wall-clock log times pairs every interval with the
    wrong input (or none), which the counters only show as ``late_input``. Two tests,
    each beyond ``max_gap_ns``:

    * both streams' stamps against the one clock of the recording, their log times:
      ``stamp - log time`` of each input against that of the measurement logged next
      (median over up to :data:`TIME_BASE_SAMPLES` inputs spread over the recording; a
      simulation that runs slower or faster than real time drifts both alike);
    * the stamp ranges themselves, for bags whose log times copy the stamps: apart by
      more than both spans together.

    Raises
    ------
    observer_ros.bags.storage.BagError
        What was found, and what to do: stamp the inputs in the measurements' clock, or
        replay with log times for both (``replay --use-log-time``,
        ``replay_bag(..., use_log_time=True)``).

    """
    if not len(outputs.stamps_ns) or not len(inputs.stamps_ns):
        return
    advice = f'stamp {u_topic} in the clock of {y_topic}, or {log_time_advice}'
    prefix = f'{bag}: ' if bag else ''
    # At most TIME_BASE_SAMPLES inputs, evenly spread, each against the measurement logged
    # at (or next after) it; float: offsets near the int64 limits, far below max_gap.
    step = max(1, len(inputs.stamps_ns) // TIME_BASE_SAMPLES)
    u_logged = inputs.log_times_ns[::step]
    u_offsets = inputs.stamps_ns[::step].astype(float) - u_logged
    at = np.minimum(np.searchsorted(outputs.log_times_ns, u_logged), len(outputs.stamps_ns) - 1)
    y_offsets = outputs.stamps_ns[at].astype(float) - outputs.log_times_ns[at]
    difference = float(np.median(u_offsets - y_offsets))
    if abs(difference) > max_gap_ns:
        raise BagError(f'{prefix}{y_topic} and {u_topic} are stamped in different time bases: '
                       f'{y_topic} {_clock(outputs)}, {u_topic} {_clock(inputs)} '
                       f'({_seconds(abs(difference))} apart, more than {_seconds(max_gap_ns)}); '
                       f'every interval would use the wrong input. {advice}')
    y_first, y_last = int(outputs.stamps_ns.min()), int(outputs.stamps_ns.max())
    u_first, u_last = int(inputs.stamps_ns.min()), int(inputs.stamps_ns.max())
    apart = max(u_first - y_last, y_first - u_last)
    if apart > max(max_gap_ns, (y_last - y_first) + (u_last - u_first)):
        raise BagError(f'{prefix}{y_topic} and {u_topic} are stamped in different time bases: '
                       f'{y_topic} spans {_seconds(y_first)} to {_seconds(y_last)}, '
                       f'{u_topic} {_seconds(u_first)} to {_seconds(u_last)} '
                       f'({_seconds(apart)} apart); every interval would use the wrong '
                       f'input. {advice}')


def stream_warnings(stream, bag: str = '', y_topic: str = 'y', u_topic: str = 'u') -> tuple:
    """
    Return the warnings of a replayed stream: the first of each kind the node warns of.

    The text is the stream's own (the observer node logs the same words), followed by the
    counters it explains and what to do offline.
    """
    first: dict = {}
    for kind, text in stream.events:
        if kind in WARNED_EVENTS:
            first.setdefault(kind, text)
    counters = stream.counters
    prefix = f'{bag}: ' if bag else ''
    warnings = []
    if 'time_base' in first:
        late = counters.get('late_input', 0) + counters.get('no_input', 0)
        warnings.append(f'{prefix}{first["time_base"]} {late} of '
                        f'{counters.get("measurements", 0)} measurements were paired with a '
                        f'late input or none; stamp {absolute_topic(u_topic)} in the clock of '
                        f'the measurements, or {LOG_TIME_ADVICE}')
    return tuple(warnings)
