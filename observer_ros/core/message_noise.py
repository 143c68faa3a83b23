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
Measurement noise from the messages: each sample's own block of ``R``, by its stamp.

A robot's sensors often say how good each sample is: an IMU's
``angular_velocity_covariance``, a localization pose's ``pose.covariance``. A source
configured with ``sources.<name>.noise: message`` hands the block of its sample (decoded
by :class:`~observer_ros.wire.covariance.CovarianceReader`) to a :class:`SampleNoise`
under the sample's stamp; the time-varying Kalman filter, the EKF and the UKF ask it for
the ``R`` of each update (:meth:`SampleNoise.block`), so a late measurement re-run through
the history finds its own noise again. Outputs without a block of their own keep the
configured ``R``; the cross terms between a message's outputs and the others are zero.
"""

from collections import deque
from typing import Optional

import numpy as np

__all__ = ['SampleNoise']


class SampleNoise:
    """
    The blocks of ``R`` that samples brought, by stamp, for the filter's updates.

    Parameters
    ----------
    keep_ns : int
        How far behind the newest stamp a block is kept (the history and the latencies:
        the stamps a re-run may take again).

    Examples
    --------
    >>> import numpy as np
    >>> noise = SampleNoise(keep_ns=100)
    >>> noise.put(5, (1,), np.array([[0.04]]))
    >>> noise.block(5, (0, 1), np.diag([1.0, 2.0])).tolist()
    [[1.0, 0.0], [0.0, 0.04]]
    >>> noise.block(6, (0, 1), np.diag([1.0, 2.0])).tolist()  # no block at 6: configured R
    [[1.0, 0.0], [0.0, 2.0]]

    """

    def __init__(self, keep_ns: int) -> None:
        self.keep_ns = int(keep_ns)
        #: ``{source name: reader}`` of the sources that fill it (set by the configuration:
        #: :func:`~observer_ros.config.message_noise.attach_message_noise`).
        self.readers: dict = {}
        self._by_stamp: dict = {}
        self._stamps: deque = deque()
        self._newest: Optional[int] = None

    def __len__(self) -> int:
        """Return how many stamps hold a block."""
        return len(self._by_stamp)

    def put(self, stamp_ns: int, outputs: tuple, block: np.ndarray) -> None:
        """
        Keep ``block`` (``(k, k)``, in the order of ``outputs``) for the sample at ``stamp_ns``.

        ``stamp_ns`` is the stamp the filter takes the sample at (its stamp less the source's
        latency). The array is kept as given (not copied): give one nobody changes. A second
        block of the same outputs at one stamp is ignored, as the event engine drops the
        second sample (a repeated stamp).
        """
        stamp_ns = int(stamp_ns)
        if self._newest is not None and stamp_ns < self._newest - self.keep_ns:
            self.clear()  # a jump back in time (a looping bag, a clock reset): start again
        parts = self._by_stamp.get(stamp_ns)
        if parts is None:
            parts = self._by_stamp[stamp_ns] = {}
            self._stamps.append(stamp_ns)
        parts.setdefault(tuple(outputs), np.asarray(block, dtype=float))
        if self._newest is None or stamp_ns > self._newest:
            self._newest = stamp_ns
        self._prune()

    def _prune(self) -> None:
        oldest = self._newest - self.keep_ns
        stamps = self._stamps
        while stamps and (stamps[0] < oldest or stamps[0] not in self._by_stamp):
            self._by_stamp.pop(stamps.popleft(), None)
        if len(stamps) > 2 * len(self._by_stamp) + 16:  # stamps out of order, pruned above
            self._stamps = deque(stamp for stamp in stamps if stamp in self._by_stamp)

    def take(self, source: str, stamp_ns: int, message) -> None:
        """Hand a message of ``source`` to its reader, which puts its block (none: no-op)."""
        reader = self.readers.get(source)
        if reader is not None:
            reader.take(stamp_ns, message)

    def has(self, stamp_ns: int) -> bool:
        """Whether a sample at ``stamp_ns`` brought a block."""
        return stamp_ns in self._by_stamp

    def block(self, stamp_ns: int, outputs: tuple, configured: np.ndarray) -> np.ndarray:
        """
        Return the ``R`` of an update with ``outputs`` at ``stamp_ns``.

        Parameters
        ----------
        stamp_ns : int
        outputs : tuple of int
            The ascending outputs of the update.
        configured : numpy.ndarray, shape (q, q)
            The configured block of ``R`` of ``outputs`` (returned as is without a block).

        Returns
        -------
        numpy.ndarray, shape (q, q)

        """
        parts = self._by_stamp.get(stamp_ns)
        if not parts:
            return configured
        if len(parts) == 1:  # the common case: the update is the one source's sample
            ((carried, block),) = parts.items()
            if carried == outputs:
                return block
        position = {output: k for k, output in enumerate(outputs)}
        noise = None
        for carried, block in parts.items():
            if not all(output in position for output in carried):
                continue  # that sample is not part of this update
            if noise is None:
                noise = np.array(configured, dtype=float)
            index = [position[output] for output in carried]
            others = [k for k in range(len(outputs)) if k not in index]
            noise[np.ix_(index, others)] = 0.0
            noise[np.ix_(others, index)] = 0.0
            noise[np.ix_(index, index)] = block
        return configured if noise is None else noise

    def clear(self) -> None:
        """Forget every block."""
        self._by_stamp.clear()
        self._stamps.clear()
        self._newest = None
