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
Sources whose measurement noise comes from their messages: ``sources.<name>.noise: message``.

:func:`attach_message_noise` gives the estimator of a stream one
:class:`~observer_ros.core.message_noise.SampleNoise` and makes a :class:`MessageNoise` per
such source; the node (and the bag replay) hands it each message of the source before the
measurement (:meth:`MessageNoise.take`), so the update at that stamp uses the block of
``R`` the message gives (:class:`~observer_ros.wire.covariance.CovarianceReader`). A block
that cannot be used (``unknown``: element 0 is -1; ``nonfinite``; ``out_of_range``;
``not_positive_definite``) is counted by its reason and the sample is taken with the
configured block of ``R``
(``sources.<name>.measurement_noise`` or ``observer.measurement_noise``): the measurement
is never lost for its covariance.
"""

from collections import Counter

from observer_ros.core.errors import ConfigError
from observer_ros.core.message_noise import SampleNoise
from observer_ros.core.units import NANOSECONDS
from observer_ros.wire import FieldPathError, FieldReader
from observer_ros.wire.covariance import CovarianceReader
from observer_ros.wire.layouts import DecodeError, HEADER

#: ``sources.<name>.noise``: the configured block of ``R``, or the message's covariance.
NOISE_CHOICES = ('configured', 'message')

#: What a source's blocks are kept for beyond the history (re-runs take them again).
KEEP_MARGIN_NS = NANOSECONDS

__all__ = ['KEEP_MARGIN_NS', 'MessageNoise', 'NOISE_CHOICES', 'attach_message_noise',
           'covariance_reader']


def covariance_reader(parameter: str, msgtype: str, fields) -> CovarianceReader:
    """
    Return the reader of a source's covariance; a ConfigError naming ``parameter`` if none.

    Raises
    ------
    ConfigError
        The type carries no covariance, or a field has none (a quaternion's ``x``).

    """
    try:
        return CovarianceReader(msgtype, fields)
    except FieldPathError as e:
        raise ConfigError(parameter, f"noise: message takes R from the message's "
                          f'covariance, but {e}') from None


class MessageNoise:
    """
    One source's covariance, read from each of its messages into the filter's ``R``.

    Attributes
    ----------
    counters : collections.Counter
        ``used`` (blocks taken from messages) and ``fallback_<reason>`` (messages whose
        block could not be used; the configured block served).

    """

    def __init__(self, source, msgtype: str, fields, store: SampleNoise,
                 parameter: str = 'sources') -> None:
        self.source = source
        self.reader = covariance_reader(parameter, msgtype, fields)
        self._fields = FieldReader(msgtype, self.reader.paths)
        self.store = store
        self.counters: Counter = Counter()

    def values(self, message) -> list:
        """Return the covariance entries the reader needs of a message (bytes or object)."""
        if isinstance(message, (bytes, bytearray, memoryview)):
            raw = bytes(message)
            if raw[:2] == HEADER[:2]:
                return self._fields.read_parts(raw)[2]
            raise DecodeError('not little-endian plain CDR')
        return self.reader.read_object(message)

    def take(self, stamp_ns: int, message) -> bool:
        """
        Keep the block of ``message`` for the sample stamped ``stamp_ns``; False: fallback.

        Call it before the stream takes the sample. A message whose covariance cannot be
        read or used is counted and its sample takes the configured block.
        """
        try:
            values = self.values(message)
        except (DecodeError, AttributeError, IndexError, TypeError, ValueError):
            self.counters['fallback_malformed'] += 1
            return False
        block, reason = self.reader.check(values)
        if block is None:
            self.counters[f'fallback_{reason}'] += 1
            return False
        self.store.put(int(stamp_ns) - self.source.latency_ns, self.source.outputs, block)
        self.counters['used'] += 1
        return True


def attach_message_noise(estimator, sources, history_ns: int) -> dict:
    """
    Give ``estimator`` the noise of the sources that take it from their messages.

    Parameters
    ----------
    estimator : Estimator
        One that reads its ``R`` per sample (``message_noise``: the time-varying Kalman
        filter, the EKF, the UKF).
    sources : SourcesSetup or None
        The checked sources (:func:`~observer_ros.config.sources.measurement_sources`).
    history_ns : int

    Returns
    -------
    dict
        ``{source name: MessageNoise}`` (empty when no source takes its noise from its
        messages; the estimator is then left as it was).

    Raises
    ------
    ConfigError
        ``sources.<name>.noise``: the observer type has no ``R`` per sample (a constant
        gain), or the message type or a field has no covariance.

    """
    if sources is None:
        return {}
    chosen = [(source, settings, msgtype) for source, settings, msgtype in zip(
        sources.sources, sources.settings, sources.msgtypes)
        if getattr(settings, 'noise', 'configured') == 'message']
    if not chosen:
        return {}
    if not hasattr(type(estimator), 'message_noise'):
        raise ConfigError(chosen[0][1].parameter('noise'), f'noise: message needs a filter '
                          f'that takes R per sample (kalman_time_varying, extended_kalman, '
                          f'unscented_kalman); {type(estimator).__name__} has a constant '
                          f'gain')
    keep = history_ns + max(source.latency_ns for source in sources.sources) + KEEP_MARGIN_NS
    store = SampleNoise(keep)
    estimator.message_noise = store
    store.readers = {source.name: MessageNoise(source, msgtype, settings.fields, store,
                                               settings.parameter('noise'))
                     for source, settings, msgtype in chosen}
    return store.readers
