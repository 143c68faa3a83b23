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

"""The vectors an estimator takes and gives: checked sizes, the feedthrough, the NIS."""

import math
from typing import Optional

import numpy as np

from observer_ros.core.errors import ConfigError


def checked_vector(name: str, values, size: int) -> np.ndarray:
    """
    Return ``values`` as a float vector of ``size`` finite entries, or raise naming ``name``.

    Raises
    ------
    ConfigError
        Another size, or a value that is not finite.

    """
    vector = values
    if type(vector) is not np.ndarray or vector.ndim != 1 or vector.dtype != float:
        vector = np.asarray(values, dtype=float).reshape(-1)
    # A finite dot product proves every entry finite (cheaper than isfinite().all()); an
    # overflow falls through to the exact check.
    if vector.size != size or (not math.isfinite(vector @ vector)
                               and not np.isfinite(vector).all()):
        raise ConfigError(name, f'expected {size} finite values, got {vector.tolist()}')
    return vector


def normalized_innovation_squared(innovation, covariance: np.ndarray) -> float:
    """Return ``v^T S^-1 v`` (inf when ``S`` is singular)."""
    innovation = np.asarray(innovation, dtype=float)
    try:
        return float(innovation @ np.linalg.solve(covariance, innovation))
    except np.linalg.LinAlgError:
        return math.inf


def without_feedthrough(d: np.ndarray, y: np.ndarray, u_now: np.ndarray,
                        outputs: Optional[tuple] = None) -> np.ndarray:
    """
    Return ``y - D u_now``: what the state alone gives of a measurement (``C x``, plus noise).

    The one place a feedthrough is taken off a measurement; every estimator then runs on
    it as on a model with ``D = 0`` (innovation ``y - C x_prior - D u_now``, the reduced-order
    and Chen reconstructions from ``y - D u_now``).

    Parameters
    ----------
    d : numpy.ndarray, shape (p, m)
    y : numpy.ndarray, shape (p,) or (q,)
        Every output, or the ``outputs`` alone.
    u_now : numpy.ndarray, shape (m,)
        The input in effect at the measurement's stamp.
    outputs : tuple of int, optional
        The outputs ``y`` holds (ascending); None: every output.

    Examples
    --------
    >>> d = np.array([[0.5], [2.0]])
    >>> without_feedthrough(d, np.array([1.0, 1.0]), np.array([2.0])).tolist()
    [0.0, -3.0]
    >>> without_feedthrough(d, np.array([1.0]), np.array([2.0]), (1,)).tolist()
    [-3.0]

    """
    if outputs is not None:
        d = d[list(outputs)]
    return y - d @ u_now
