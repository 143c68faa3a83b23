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
The state-feedback law ``u = sat(-K x_hat + N r + K_i z)``, with optional integral action.

Integral action (servo form) integrates the tracking error of chosen outputs with the
*measured* ``y`` (an observer without a model of the load has a biased ``x_hat`` under a
constant load, so ``C x_hat`` would be driven to ``r`` instead of ``y``). The accumulation is
a zero-order hold of the error: the command stamped ``t_k`` uses

``z_k = z_(k-1) + h_k (r_(k-1) - y_i(t_(k-1)))``

where ``t_(k-1)`` is the stamp of the previous command, ``y_i(t_(k-1))`` the latest
measurement stamped at or before it, ``r_(k-1)`` the reference then, and ``h_k`` the model
period ``T`` for a discrete model or ``t_k - t_(k-1)`` in seconds for a continuous one (the
discrete form is exactly the augmented model :mod:`observer_ros.core.design.integral`
designs for). With a modelled sensor bias the estimate carries it, and ``output_bias``
(``E``, q x n, :class:`IntegralAction`) takes it out: the error is
``r_(k-1) - (y_i(t_(k-1)) - E x_hat(t_(k-1)))``, so the true output, not the biased reading,
goes to the reference. Anti-windup is conditional integration: when the command with the new ``z``
is saturated and the step's increment ``K_i h e`` pushes a saturated input further out, the
increment is dropped (``z`` keeps its value), so ``z`` never grows while the actuator is at
its limit in the direction of the error.
"""

import bisect
from typing import Optional, Sequence

import numpy as np

from observer_ros.core.angles import wrap_angles
from observer_ros.core.errors import ConfigError


class StateFeedbackLaw:
    """
    ``u = -K x_hat + N r``, clipped to the input limits.

    At an operating point ``(x0, u0)`` of equations: ``u = u0 - K (x_hat - x0) + N r``.

    Parameters
    ----------
    gain : array_like, shape (m, n)
        ``K``.
    reference_gain : array_like or None, shape (m, p)
        ``N``; None: references are ignored.
    input_limits : array_like or None, shape (m, 2)
        ``[min, max]`` per input; None: no clipping.
    operating_point : tuple or None
        ``(x0, u0, angles)`` of a gain designed on equations linearized at ``(x0, u0)``
        (``model.operating_point_states``, ``model.operating_point_inputs``): the law acts on
        the deviation ``x_hat - x0``, its entries at the indices ``angles`` wrapped to
        ``(-pi, pi]``, and adds ``u0``. None: ``x0 = 0``, ``u0 = 0``.

    Raises
    ------
    ConfigError
        Naming ``gain``, ``reference_gain`` or ``input_limits`` when the shapes disagree.

    Examples
    --------
    >>> import numpy as np
    >>> import observer_ros.core as oc
    >>> law = oc.StateFeedbackLaw([[5.0, 4.5]], reference_gain=[[5.0]],
    ...                           input_limits=[[-10.0, 10.0]])
    >>> law.command(np.array([1.0, 0.0]), reference=np.array([2.0])).tolist()
    [5.0]
    >>> law.command(np.array([4.0, 0.0])).tolist()
    [-10.0]

    """

    def __init__(self, gain: np.ndarray, reference_gain: Optional[np.ndarray] = None,
                 input_limits: Optional[np.ndarray] = None,
                 integral: Optional['IntegralAction'] = None,
                 operating_point: Optional[tuple] = None) -> None:
        self.gain = np.atleast_2d(np.asarray(gain, dtype=float))
        if self.gain.ndim != 2:
            raise ConfigError('gain', f'expected an m x n matrix, got shape {self.gain.shape}')
        n_inputs = self.gain.shape[0]
        if reference_gain is not None:
            reference_gain = np.atleast_2d(np.asarray(reference_gain, dtype=float))
            if reference_gain.ndim != 2 or reference_gain.shape[0] != n_inputs:
                raise ConfigError('reference_gain', f'expected a {n_inputs} x p matrix, got '
                                  f'shape {reference_gain.shape}')
        if input_limits is not None:
            input_limits = np.atleast_2d(np.asarray(input_limits, dtype=float))
            if input_limits.shape != (n_inputs, 2):
                raise ConfigError('input_limits', f'expected a {n_inputs} x 2 matrix '
                                  f'([min, max] per input), got shape {input_limits.shape}')
        self.reference_gain = reference_gain
        self.input_limits = input_limits
        if integral is not None and integral.gain.shape[0] != n_inputs:
            raise ConfigError('integral_gain', f'expected {n_inputs} rows, got '
                              f'{integral.gain.shape[0]}')
        self.integral = integral
        self.operating_point = None
        if operating_point is not None:
            x0, u0, angles = operating_point
            x0, u0 = np.asarray(x0, dtype=float), np.asarray(u0, dtype=float)
            if x0.shape != (self.gain.shape[1],) or u0.shape != (n_inputs,):
                raise ConfigError('operating_point', f'expected x0 of {self.gain.shape[1]} and '
                                  f'u0 of {n_inputs} values, got {x0.shape} and {u0.shape}')
            self.operating_point = (x0, u0, np.asarray(angles, dtype=int))

    def command(self, estimate: np.ndarray, reference: Optional[np.ndarray] = None,
                stamp_ns: Optional[int] = None):
        """
        Return the command for an estimate and an optional reference.

        Parameters
        ----------
        estimate : numpy.ndarray, shape (n,)
            ``x_hat``.
        reference : numpy.ndarray, shape (p,), optional
            ``r``; ignored without a reference gain and integral action.
        stamp_ns : int, optional
            Stamp of ``x_hat``; integral action integrates up to it (see the module notes).

        Returns
        -------
        numpy.ndarray, shape (m,)

        Examples
        --------
        >>> import numpy as np
        >>> from observer_ros.core import StateFeedbackLaw
        >>> StateFeedbackLaw([[1.0, 2.0]]).command(np.array([1.0, 1.0])).tolist()
        [-3.0]

        """
        if self.operating_point is None:
            u = -self.gain @ estimate
        else:
            x0, u0, angles = self.operating_point
            deviation = estimate - x0
            if angles.size:
                deviation[angles] = wrap_angles(deviation[angles])
            u = u0 - self.gain @ deviation
        if reference is not None and self.reference_gain is not None:
            u = u + self.reference_gain @ reference
        if self.integral is not None:
            u = self.integral.command(u, reference, stamp_ns, self.input_limits, estimate)
        if self.input_limits is not None:  # np.clip's result, at a third of its cost
            u = np.minimum(np.maximum(u, self.input_limits[:, 0]), self.input_limits[:, 1])
        return u


class IntegralAction:
    """
    The integrator of the servo law: ``z`` of the measured outputs' tracking error.

    Parameters
    ----------
    gain : array_like, shape (m, q)
        ``K_i``.
    outputs : sequence of int, shape (q,)
        Indices of the integrated outputs in ``y`` and ``r``.
    period : float
        The model period ``T`` (a discrete model), or 0 for a continuous model (then the
        interval between commands is used).
    anti_windup : bool
        Conditional integration under the input limits (see the module notes).
    output_bias : array_like or None, shape (q, n)
        ``E``: the sensor bias of the integrated outputs in the estimate, ``E x_hat``
        (taken from the measured outputs before they are integrated); None: no bias.

    Attributes
    ----------
    state : numpy.ndarray, shape (q,)
        ``z``.
    skipped : int
        Increments dropped by the anti-windup.

    Examples
    --------
    >>> import numpy as np
    >>> from observer_ros.core.feedback_law import IntegralAction, StateFeedbackLaw
    >>> law = StateFeedbackLaw([[4.0]], integral=IntegralAction([[6.0]], [0], period=0.1))
    >>> law.integral.measure(0, [0.0])
    >>> law.command(np.zeros(1), np.array([1.0]), stamp_ns=0).tolist()
    [0.0]
    >>> law.command(np.zeros(1), np.array([1.0]), stamp_ns=100_000_000).tolist()
    [0.6000000000000001]

    """

    #: Measurements kept for the integrator (older ones are never needed).
    HISTORY = 64

    def __init__(self, gain, outputs: Sequence[int], period: float = 0.0,
                 anti_windup: bool = True, output_bias=None) -> None:
        self.gain = np.atleast_2d(np.asarray(gain, dtype=float))
        self.outputs = list(outputs)
        if self.gain.shape[1] != len(self.outputs):
            raise ConfigError('integral_gain', f'expected {len(self.outputs)} columns (one per '
                              f'integrated output), got shape {self.gain.shape}')
        self.period = float(period)
        self.anti_windup = anti_windup
        self.output_bias = None
        if output_bias is not None:
            self.output_bias = np.atleast_2d(np.asarray(output_bias, dtype=float))
            if self.output_bias.shape[0] != len(self.outputs):
                raise ConfigError('output_bias', f'expected {len(self.outputs)} rows (one per '
                                  f'integrated output), got shape {self.output_bias.shape}')
        self.state = np.zeros(len(self.outputs))
        self.skipped = 0
        self._stamps: list = []
        self._values: list = []
        self._previous: Optional[tuple] = None  # (stamp, reference) of the last command

    def reset(self) -> None:
        """Set ``z`` to zero and forget the previous command (measurements are kept)."""
        self.state = np.zeros(len(self.outputs))
        self._previous = None

    def measure(self, stamp_ns: int, y) -> None:
        """Keep the integrated entries of a measurement ``y`` stamped ``stamp_ns``."""
        stamp_ns = int(stamp_ns)
        values = np.asarray(y, dtype=float)[self.outputs]
        index = bisect.bisect_left(self._stamps, stamp_ns)
        if index < len(self._stamps) and self._stamps[index] == stamp_ns:
            self._values[index] = values
            return
        self._stamps.insert(index, stamp_ns)
        self._values.insert(index, values)
        if len(self._stamps) > self.HISTORY:
            del self._stamps[0], self._values[0]

    def _measured_at(self, stamp_ns: int) -> Optional[np.ndarray]:
        """Return the latest measurement stamped at or before ``stamp_ns`` (None: none)."""
        index = bisect.bisect_right(self._stamps, stamp_ns) - 1
        return None if index < 0 else self._values[index]

    def command(self, u: np.ndarray, reference: Optional[np.ndarray],
                stamp_ns: Optional[int], limits: Optional[np.ndarray],
                estimate: Optional[np.ndarray] = None) -> np.ndarray:
        """
        Return ``u + K_i z`` after integrating up to ``stamp_ns`` (unclipped).

        ``estimate`` (``x_hat`` of this command) gives the sensor bias the next step takes
        out of the measurement (with ``output_bias``).
        """
        r = (np.zeros(len(self.outputs)) if reference is None
             else np.asarray(reference, dtype=float)[self.outputs])
        bias = (None if self.output_bias is None or estimate is None
                else self.output_bias @ np.asarray(estimate, dtype=float))
        previous, self._previous = self._previous, (stamp_ns, r, bias)
        if stamp_ns is not None and previous is not None and previous[0] is not None:
            step_ns = int(stamp_ns) - int(previous[0])
            if step_ns <= 0:  # time went back (a restart): start the integral afresh
                self.state = np.zeros(len(self.outputs))
            else:
                measured = self._measured_at(previous[0])
                if measured is not None and previous[2] is not None:
                    measured = measured - previous[2]  # the true output, not the reading
                if measured is not None:
                    h = self.period or step_ns / 1e9
                    self._integrate(u, h * (previous[1] - measured), limits)
        return u + self.gain @ self.state

    def _integrate(self, u: np.ndarray, increment: np.ndarray,
                   limits: Optional[np.ndarray]) -> None:
        candidate = self.state + increment
        if self.anti_windup and limits is not None:
            command = u + self.gain @ candidate
            push = self.gain @ increment
            outward = (((command > limits[:, 1]) & (push > 0))
                       | ((command < limits[:, 0]) & (push < 0)))
            if outward.any():
                self.skipped += 1
                return
        self.state = candidate
