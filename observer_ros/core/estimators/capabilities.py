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

"""What an estimator may offer besides the protocol: a pinned start, fast paths, subsets."""

from abc import ABC, abstractmethod
from typing import Optional

import numpy as np

from observer_ros.core.estimators.vectors import checked_vector


class PinnedInitialState:
    """
    ``initial_state`` of an estimator that may be pinned: kept checked in ``_pinned``.

    None means the first measurement initialises the estimate (the time-varying filter then
    starts from a zero prior). Mixed in before :class:`Estimator` by both engines.
    """

    _pinned: Optional[np.ndarray] = None
    n_states: int

    @property
    def initial_state(self) -> Optional[np.ndarray]:
        """The pinned initial estimate, or None when the first measurement initialises it."""
        return None if self._pinned is None else self._pinned.copy()

    @initial_state.setter
    def initial_state(self, values) -> None:
        self._pinned = (None if values is None else
                        checked_vector('initial_state', values, self.n_states))


class SteadySteps(ABC):
    """
    Fast paths an estimator may offer (a capability; the stream asks with ``isinstance``).

    Each gives the numbers :meth:`Estimator.advance` gives, bit for bit: the stream uses them
    as a private optimisation, and its tests hold them equal to the general path.
    """

    @property
    @abstractmethod
    def result(self) -> Optional[np.ndarray]:
        """``[x_hat; innovation]`` of the last step when the estimator keeps one, or None."""

    @abstractmethod
    def prepare(self, u: np.ndarray, limits: Optional[tuple] = None) -> None:
        """Make the next step's known part now, with the input ``u`` held over it."""

    @abstractmethod
    def advance_prepared(self, stamp_ns: int, y: float, u: np.ndarray) -> Optional[tuple]:
        """Take a prepared steady one-output step: ``(result, bounded)``, or None."""

    @abstractmethod
    def advance_many(self, stamps_ns, outputs, inputs) -> tuple:
        """Run many samples at once: ``(estimates, innovations)``, as advance one by one."""


class SubsetUpdates(ABC):
    """
    Updates with some of the outputs: several measurement sources, each at its own rate.

    A capability (the stream asks with ``isinstance``). ``outputs`` is a tuple of ascending
    output indices; the empty tuple predicts over the interval without a correction (a
    predict-only source). The estimate, covariance and stamps are the ones
    :meth:`Estimator.advance` keeps, so updates with all outputs and with some of them
    follow each other freely; after an update with some outputs, :attr:`Estimator.innovation`
    and :attr:`Estimator.innovation_covariance` have their size.
    """

    def several_sources_problem(self) -> Optional[str]:
        """
        Say why this estimator takes no several sources at all (None: it does).

        An estimator whose implementation can update with some outputs may still be made
        for a design that needs every output at each update (a reduced-order observer); it
        says so here, and a configuration of several sources is refused with that reason.
        """
        return None

    @abstractmethod
    def subset_problem(self, outputs: tuple) -> Optional[str]:
        """
        Say why an update from ``outputs`` alone cannot be made (None: it can).

        Asked at start-up for each source (:func:`~observer_ros.core.sources.check_subsets`):
        for a design made per subset of outputs, an unobservable (or undetectable) subset,
        naming the modes the outputs cannot see.
        """

    @abstractmethod
    def advance_outputs(self, stamp_ns: int, y: np.ndarray, u: np.ndarray,
                        outputs: tuple) -> np.ndarray:
        """
        Take the values ``y`` of ``outputs`` (checked already); return the estimate.

        With every output this is :meth:`Estimator.advance` exactly; with none, a
        prediction to ``stamp_ns``.
        """
