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
What every runtime estimator does: the protocol :class:`Estimator`.

An estimator takes a measurement at the end of a sample interval together with the input
held over it (predict over the interval, then update), holds its current estimate, predicts
ahead without changing anything, and can be reset. A covariance is a capability: an
estimator without one returns None for :attr:`Estimator.covariance`,
:attr:`~Estimator.innovation_covariance` and :attr:`~Estimator.nis`.

:class:`~observer_ros.core.streaming.EventStream` drives any estimator through this protocol
alone. An implementation may also offer the fast paths of :class:`SteadySteps` (a prepared
steady step, a batch over many samples, equal bit for bit to :meth:`Estimator.advance`); the
stream takes them when it is given one, as a private optimisation. An estimator that can
update with some of the outputs (several measurement sources at their own rates) offers
:class:`SubsetUpdates`; the stream asks for it with ``isinstance``, never by type name.

Two implementations exist: the
:class:`~observer_ros.core.estimators.constant_gain.ConstantGainEstimator` (one matrix per
sample interval: every Luenberger type and the steady-state Kalman filter; it offers
:class:`SteadySteps`) and the
:class:`~observer_ros.core.observers.kalman.time_varying.TimeVaryingKalman`, which carries
its covariance.
"""

from abc import ABC, abstractmethod
from typing import NamedTuple, Optional

import numpy as np

from observer_ros.core.errors import ConfigError
from observer_ros.core.estimators.capabilities import (
    PinnedInitialState, SteadySteps, SubsetUpdates)
from observer_ros.core.estimators.vectors import (
    checked_vector, normalized_innovation_squared, without_feedthrough)
from observer_ros.core.model import model_feedthrough

__all__ = ['Estimator', 'PinnedInitialState', 'Prediction', 'SteadySteps', 'SubsetUpdates',
           'checked_vector', 'model_feedthrough', 'normalized_innovation_squared',
           'without_feedthrough']


class Prediction(NamedTuple):
    """
    An estimate predicted to a stamp: ``x_hat`` and, with a covariance, ``P``.

    Attributes
    ----------
    stamp_ns : int
    estimate : numpy.ndarray, shape (n,)
    covariance : numpy.ndarray or None, shape (n, n)

    Examples
    --------
    >>> Prediction(5, [1.0], None).stamp_ns
    5

    """

    stamp_ns: int
    estimate: np.ndarray
    covariance: Optional[np.ndarray]


class Estimator(ABC):
    """
    A discrete-time state estimator driven by stamped samples.

    Attributes
    ----------
    n_states, n_inputs, n_outputs : int

    Notes
    -----
    :meth:`update` (checked) and :meth:`advance` (values already checked) take the
    measurement ``y`` stamped ``stamp_ns`` and the input ``u`` held since the previous
    sample; the first sample (and the first after :meth:`reset` or :meth:`restart`) starts
    the estimate. :meth:`predict` looks ahead without changing anything. :meth:`snapshot`
    and :meth:`restore` return to an earlier running state (a re-run from a history).

    Examples
    --------
    >>> from observer_ros.core import design_kalman, make_estimator, StateSpaceModel
    >>> model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> filter_ = make_estimator(design_kalman(model, [0.0, 1.0], [0.01]), time_varying=True)
    >>> isinstance(filter_, Estimator), isinstance(filter_, SteadySteps)
    (True, False)

    """

    n_states: int
    n_inputs: int
    n_outputs: int

    @property
    @abstractmethod
    def stamp_ns(self) -> Optional[int]:
        """Stamp of the last sample taken, None before the first one."""

    @property
    @abstractmethod
    def estimate(self) -> np.ndarray:
        """Current estimate ``x_hat``, shape ``(n,)`` (a copy)."""

    @property
    @abstractmethod
    def innovation(self) -> np.ndarray:
        """Last innovation ``y - C x_prior``, shape ``(p,)``."""

    @property
    def covariance(self) -> Optional[np.ndarray]:
        """Covariance of the estimate, ``(n, n)``; None for observers without one."""
        return None

    @property
    def innovation_covariance(self) -> Optional[np.ndarray]:
        """Covariance ``S`` of the last innovation, ``(p, p)``; None without one."""
        return None

    @property
    def nis(self) -> Optional[float]:
        """Normalised innovation squared ``v^T S^-1 v`` of the last sample, or None."""
        covariance = self.innovation_covariance
        if covariance is None:
            return None
        return normalized_innovation_squared(self.innovation, covariance)

    @property
    def last_interval_ns(self) -> int:
        """The interval of the last step in nanoseconds (0 at a first sample)."""
        return 0

    @property
    @abstractmethod
    def initial_state(self) -> Optional[np.ndarray]:
        """The pinned initial estimate, or None when it is not pinned."""

    #: ``D`` of the model, ``(p, m)``, when it is not zero; None: no feedthrough (``D = 0``).
    feedthrough: Optional[np.ndarray] = None

    def update(self, stamp_ns: int, y, u, u_now=None) -> np.ndarray:
        """
        Take ``y`` at ``stamp_ns`` with ``u`` held since the last sample; return the estimate.

        ``u_now`` is the input in effect at ``stamp_ns`` (the one held over the next
        interval): with a feedthrough ``D`` the measurement is ``y = C x + D u_now``, and
        ``D u_now`` is taken off ``y`` before the update (:func:`without_feedthrough`).
        Without a feedthrough it is not used.

        Raises
        ------
        StampError
            The stamp is not after the previous sample's.
        ConfigError
            ``y``, ``u`` or ``u_now`` has the wrong length or a non-finite entry, or
            ``u_now`` is missing for a model with a feedthrough.

        """
        y = checked_vector('y', y, self.n_outputs)
        d = self.feedthrough
        if d is not None:
            if u_now is None:
                raise ConfigError('u_now', 'the model has a feedthrough D != 0: give the input '
                                  'in effect at the stamp of the measurement')
            y = without_feedthrough(d, y, checked_vector('u_now', u_now, self.n_inputs))
        return self.advance(int(stamp_ns), y, checked_vector('u', u, self.n_inputs))

    @abstractmethod
    def advance(self, stamp_ns: int, y: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Take a sample whose values are checked already; return the estimate."""

    def predict(self, stamp_ns: int, u: np.ndarray) -> Prediction:
        """
        Return the estimate predicted to ``stamp_ns`` with ``u`` held; change nothing.

        Before the first sample, or for a stamp not after the last one, the current
        estimate (and covariance).
        """
        stamp = self.stamp_ns
        interval = 0 if stamp is None or stamp_ns <= stamp else stamp_ns - stamp
        prediction = self.prediction(self.estimate, self.covariance, interval, u)
        return prediction._replace(stamp_ns=int(stamp_ns))

    @abstractmethod
    def prediction(self, estimate: np.ndarray, covariance: Optional[np.ndarray],
                   interval_ns: int, u: np.ndarray) -> Prediction:
        """
        Return ``estimate`` (and ``covariance``) carried over ``interval_ns`` with ``u``.

        ``x = Ad x + Bd u`` and ``P = Ad P Ad^T + Qd``; an interval of 0 changes nothing.
        The one arithmetic of every prediction (live and batch), so they agree bit for bit.
        """

    @abstractmethod
    def reset(self, initial_state=None) -> None:
        """Forget everything and start again as configured (``initial_state`` pins it)."""

    @abstractmethod
    def restart(self) -> None:
        """Forget the stamps; the next sample starts from the estimate held."""

    @abstractmethod
    def snapshot(self) -> tuple:
        """Return the running state, for :meth:`restore`."""

    @abstractmethod
    def restore(self, state: tuple) -> None:
        """Return to a state taken by :meth:`snapshot`."""

    @abstractmethod
    def adopt(self, other: 'Estimator') -> None:
        """
        Take the design of ``other`` (same kind and sizes) and keep the running state.

        How a run-time change of gains, poles or noises reaches a running estimator: the
        estimate, the stamps (and a covariance) go on, so ``x_hat`` does not jump.
        """

    #: The :class:`~observer_ros.core.angles.Angles` kept (:meth:`keep_angles`); None: none.
    angles = None

    def keep_angles(self, angles) -> None:
        """
        Wrap the innovations of angle outputs and keep angle states in ``(-pi, pi]``.

        ``angles``: :class:`~observer_ros.core.angles.Angles` checked against the model
        (:func:`~observer_ros.core.angles.check_angles`). This default refuses any: an
        estimator that can keep them overrides it.

        Raises
        ------
        ConfigError
            ``angle_outputs`` (or ``angle_states``): this estimator cannot keep angles.

        """
        if angles:
            raise ConfigError('angle_outputs' if angles.outputs else 'angle_states',
                              f'this estimator ({type(self).__name__}) cannot wrap angles; '
                              f'expected none')

    def recent_intervals(self) -> list:
        """Return the last few distinct sample intervals (ns) designed for (default: none)."""
        return []

    def try_intervals(self, intervals_ns) -> None:
        """Design (or sample) for each interval now; raise what a sample would raise."""
