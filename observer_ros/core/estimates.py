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

"""What an event stream returns: one estimate, or the arrays of a replay."""

from dataclasses import dataclass
from typing import Optional

import numpy as np

from observer_ros.core.estimators.protocol import normalized_innovation_squared


class EstimateSample:
    """
    One published estimate: stamp, ``x_hat``, innovation and what a Kalman filter adds.

    ``covariance`` is ``P`` of the published estimate (``(n, n)``), ``innovation_covariance``
    the ``S`` of the innovation (``(p, p)``) and ``nis`` ``v^T S^-1 v`` (computed from the
    two when first read, if not given); None without them. ``estimate`` and ``innovation``
    are sequences of floats (arrays, or lists on the steady path).

    With several measurement sources: ``outputs``, the ascending output indices the
    innovation (and ``S``) is of (None: every output; empty: a prediction without
    correction); ``corrected``, the estimate was computed again after a late measurement
    (it is the newest estimate, at the newest stamp, which an earlier sample had already
    given before the correction).

    Examples
    --------
    >>> EstimateSample(10, [1.0, 0.0], [0.5], innovation_covariance=[[0.25]]).nis
    1.0

    """

    __slots__ = ('stamp_ns', 'estimate', 'innovation', 'covariance', 'innovation_covariance',
                 '_nis')

    #: Every output, not corrected: a sample of one source (:class:`SourceSample` sets them).
    outputs: Optional[tuple] = None
    corrected: bool = False

    def __init__(self, stamp_ns: int, estimate, innovation, covariance=None,
                 innovation_covariance=None, nis: Optional[float] = None) -> None:
        self.stamp_ns = stamp_ns
        self.estimate = estimate
        self.innovation = innovation
        self.covariance = covariance
        self.innovation_covariance = innovation_covariance
        self._nis = nis

    @property
    def nis(self) -> Optional[float]:
        """``v^T S^-1 v`` of the innovation, or None without ``S``."""
        if self._nis is None and self.innovation_covariance is not None:
            self._nis = normalized_innovation_squared(self.innovation,
                                                      self.innovation_covariance)
        return self._nis

    def _replace(self, **changes) -> 'EstimateSample':
        fields = {'stamp_ns': self.stamp_ns, 'estimate': self.estimate,
                  'innovation': self.innovation, 'covariance': self.covariance,
                  'innovation_covariance': self.innovation_covariance, 'nis': self._nis}
        if type(self) is not EstimateSample or {'outputs', 'corrected'} & set(changes):
            fields.update(outputs=self.outputs, corrected=self.corrected)
            fields.update(changes)
            return SourceSample(**fields)
        fields.update(changes)
        return EstimateSample(**fields)

    def __repr__(self) -> str:
        return f'EstimateSample(stamp_ns={self.stamp_ns}, estimate={list(self.estimate)})'


class SourceSample(EstimateSample):
    """
    An :class:`EstimateSample` of several sources, or corrected after a late measurement.

    Examples
    --------
    >>> sample = SourceSample(10, [1.0, 0.0], [0.5], outputs=(1,), corrected=True)
    >>> sample.outputs, sample.corrected, EstimateSample(10, [1.0], [0.5]).corrected
    ((1,), True, False)

    """

    __slots__ = ('outputs', 'corrected')

    def __init__(self, stamp_ns: int, estimate, innovation, covariance=None,
                 innovation_covariance=None, nis: Optional[float] = None,
                 outputs: Optional[tuple] = None, corrected: bool = False) -> None:
        self.stamp_ns = stamp_ns  # EstimateSample's fields set here: one call per sample
        self.estimate = estimate
        self.innovation = innovation
        self.covariance = covariance
        self.innovation_covariance = innovation_covariance
        self._nis = nis
        self.outputs = outputs
        self.corrected = corrected


@dataclass(frozen=True)
class ReplayArrays:
    """
    Estimates of a batch replay, one row per published estimate.

    Attributes
    ----------
    stamps_ns : numpy.ndarray of int64, shape (k,)
    estimates : numpy.ndarray, shape (k, n)
    innovations : numpy.ndarray, shape (k, p)
    covariances : numpy.ndarray or None, shape (k, n, n)
        Kalman filters: ``P`` of each estimate.
    innovation_covariances : numpy.ndarray or None, shape (k, p, p)
        Kalman filters: ``S`` of each innovation.
    nis : numpy.ndarray or None, shape (k,)
        Kalman filters: the normalised innovation squared.

    """

    stamps_ns: np.ndarray
    estimates: np.ndarray
    innovations: np.ndarray
    covariances: Optional[np.ndarray] = None
    innovation_covariances: Optional[np.ndarray] = None
    nis: Optional[np.ndarray] = None


def replay_arrays(samples: list, n_states: int, n_outputs: int) -> ReplayArrays:
    """Stack estimate samples into :class:`ReplayArrays` (the Kalman arrays when all have)."""
    stamps = np.array([s.stamp_ns for s in samples], dtype=np.int64)
    estimates = np.array([s.estimate for s in samples]).reshape(-1, n_states)
    innovations = np.array([s.innovation for s in samples]).reshape(-1, n_outputs)
    covariances = innovation_covariances = nis = None
    if samples and all(s.covariance is not None for s in samples):
        covariances = np.array([s.covariance for s in samples])
    if samples and all(s.innovation_covariance is not None for s in samples):
        innovation_covariances = np.array([s.innovation_covariance for s in samples])
        nis = np.array([s.nis for s in samples], dtype=float)
    return ReplayArrays(stamps, estimates, innovations, covariances, innovation_covariances,
                        nis)
