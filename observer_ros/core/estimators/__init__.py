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
Runtime estimators: the protocol, the constant-gain engine and the time-varying Kalman filter.

:class:`Estimator` is the protocol the stream drives; :class:`ConstantGainEstimator` runs
one matrix per sample interval from a step design (one per Luenberger type and the
steady-state Kalman filter); :class:`TimeVaryingKalman` carries its covariance. The observer
types (:mod:`observer_ros.core.observers`) say which one a design runs on.
"""

from observer_ros.core.design.common import ObserverDesign
from observer_ros.core.estimators.chen import ChenStep
from observer_ros.core.estimators.constant_gain import (
    ConstantGainEstimator, StepDesign, StepMatrices)
from observer_ros.core.estimators.full_order import FullOrderStep
from observer_ros.core.estimators.intervals import IntervalCache
from observer_ros.core.estimators.kalman import KalmanStep
from observer_ros.core.estimators.protocol import Estimator, Prediction, SteadySteps
from observer_ros.core.estimators.reduced_order import ReducedOrderStep
from observer_ros.core.estimators.time_varying_kalman import TimeVaryingKalman


def make_estimator(design: ObserverDesign, initial_state=None, method: str = 'auto',
                   interval_resolution_ns: int = 0, **options) -> Estimator:
    """
    Build the runtime estimator of an observer design, through its registered type.

    Parameters
    ----------
    design : ObserverDesign
        From any design function; its ``kind`` names the observer type.
    initial_state : array_like, shape (n,), optional
        Pins the first estimate (see :class:`ConstantGainEstimator`).
    method : str
        Placement method of the per-interval designs (pole-placed types).
    interval_resolution_ns : int
        Round intervals to multiples of this before designing them (0: exact).
    **options
        Further arguments of the type (``time_varying=True``, ``initial_covariance=...``
        for ``kalman``).

    Returns
    -------
    Estimator
        The type's runtime estimator: a :class:`ConstantGainEstimator`, or a
        :class:`TimeVaryingKalman` for ``kalman`` with ``time_varying=True``.

    Raises
    ------
    ConfigError
        ``type``: the design's kind is no registered observer type; or a bad option.

    Examples
    --------
    >>> from observer_ros.core import design_kalman, StateSpaceModel
    >>> model = StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> design = design_kalman(model, [0.0, 1.0], [0.01])
    >>> type(make_estimator(design)).__name__
    'ConstantGainEstimator'
    >>> type(make_estimator(design, time_varying=True)).__name__
    'TimeVaryingKalman'

    """
    from observer_ros.core.observers import observer_type  # the types import this module
    kind = observer_type(design.kind)
    values = kind.values({'method': method, **options})
    return kind.estimator(design, values, initial_state, interval_resolution_ns)


__all__ = ['ChenStep', 'ConstantGainEstimator', 'Estimator', 'FullOrderStep', 'IntervalCache',
           'KalmanStep', 'Prediction', 'ReducedOrderStep', 'SteadySteps', 'StepDesign',
           'StepMatrices', 'TimeVaryingKalman', 'make_estimator']
