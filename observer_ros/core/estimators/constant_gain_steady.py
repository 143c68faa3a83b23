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

"""The steady fast paths of the constant-gain estimator (SteadySteps)."""

from math import isfinite
from typing import Optional

import numpy as np

from observer_ros.core.estimators.protocol import SteadySteps
from observer_ros.core.estimators.steps import output_term


class ConstantGainSteady(SteadySteps):
    """The constant-gain estimator's fast paths: a prepared steady step, a batch."""

    def prepare(self, u: np.ndarray, limits: Optional[tuple] = None) -> None:
        """
        Make the next step's product with the estimate and the input ``u`` now.

        For an input known before the measurement that ends its interval: the next
        :meth:`advance` with this ``u`` (the same array) over an interval of the last
        length only adds the measurement's part. The result is the same either way.
        ``limits``, ``(largest |y|, largest |result entry|)``, lets
        :meth:`advance_prepared` say whether every ``y`` within the first keeps the result
        within the second.
        """
        step = self.intervals.last
        if self._stamp is None or step is None or self.angles is not None:
            return
        prepared = self._prepared
        if prepared is not None and prepared[0] is self._x and prepared[1] is u:
            return
        known = self._known_part(step, u)
        floats, bounded = None, False
        if self.n_outputs == 1:  # for advance_prepared: the same sums on Python floats
            floats = known_list, g_y = known.tolist(), step.g_y_column.tolist()
            if limits is not None:  # |known| + |g_y| |y|, entry by entry, as numpy would
                largest_y = float(limits[0])
                reach = [abs(k) + abs(g) * largest_y for k, g in zip(known_list, g_y)]
                bounded = bool(all(map(isfinite, reach)) and max(reach) <= limits[1])
        self._prepared = (self._x, u, step, known, self.intervals.last_dt_ns, floats, bounded)

    def advance_prepared(self, stamp_ns: int, y: float, u: np.ndarray) -> Optional[tuple]:
        """
        Return ``([x_hat..., innovation...], bounded)`` of a prepared step, or None.

        The steady case of :meth:`advance` for one output: :meth:`prepare` was called with
        this ``u`` (the same array) and the interval has the last length. The numbers, as
        Python floats, are those :meth:`advance` gives (the same products and sums).
        ``bounded``: the result is known to lie within the limits given to :meth:`prepare`
        for any ``y`` within them. None when the steady case does not hold; the estimator
        is then untouched.
        """
        prepared = self._prepared
        if (self.angles is not None or prepared is None or prepared[5] is None
                or prepared[0] is not self._x
                or prepared[1] is not u or stamp_ns - self._stamp != prepared[4]
                or prepared[2] is not self.intervals.last):
            return None
        known, g_y = prepared[5]
        result = [k + g * y for k, g in zip(known, g_y)]  # known + output_term(step, [y])
        self._fresh = result  # x, innovation and result, as arrays when read
        self._stamp, self._step, self._prepared = stamp_ns, prepared[2], None
        return result, prepared[6]

    def advance_many(self, stamps_ns: np.ndarray, outputs: np.ndarray,
                     inputs: np.ndarray) -> tuple:
        """
        Run :meth:`advance` over increasing stamps at once; equal to it bit for bit.

        Row ``k`` of ``inputs`` is held from sample ``k-1`` to ``k``; every row must be
        checked already (finite, right sizes) and the stamps must increase. The products are
        the same matrix-vector products as :meth:`advance` (written into preallocated rows
        instead of new arrays), so the results are identical.

        Returns
        -------
        estimates : numpy.ndarray, shape (samples, n)
        innovations : numpy.ndarray, shape (samples, p)

        """
        count = len(stamps_ns)
        n, m = self.n_states, self.n_inputs
        results = np.empty((count, n + self.n_outputs))
        if count == 0:
            return results[:, :n], results[:, n:]
        if self.angles is not None:  # angles wrap each step: the general path, row by row
            for k in range(count):
                results[k, :n] = self.advance(int(stamps_ns[k]), outputs[k], inputs[k])
                results[k, n:] = self._innovation
            return results[:, :n], results[:, n:]
        results[0, :n] = self.advance(int(stamps_ns[0]), outputs[0], inputs[0])
        results[0, n:] = self._innovation
        work = np.empty((count, n + m))
        work[:, n:] = inputs
        steps = [self.step_matrices(dt) for dt in np.diff(stamps_ns).tolist()]
        if steps and all(step is steps[0] for step in steps) and self.n_outputs == 1:
            terms = outputs[:, :1] * steps[0].g_y_column  # output_term for every sample
        else:
            terms = [output_term(step, y) for step, y in zip(steps, outputs[1:])]
            terms.insert(0, None)
        dot, add = np.dot, np.add
        known = np.empty(n + self.n_outputs)
        for k in range(1, count):
            work[k, :n] = results[k - 1, :n]
            dot(steps[k - 1].g_known, work[k], out=known)
            add(known, terms[k], out=results[k])
        self._prepared = None
        if count > 1:
            self._x = results[-1, :n].copy()
            self._innovation = results[-1, n:].copy()
            self._result = None
            self._stamp = int(stamps_ns[-1])
            self._step = self.step_matrices(int(stamps_ns[-1] - stamps_ns[-2]))
        return results[:, :n], results[:, n:]
