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
One event's path through the engine: its cost beside the filter update's, hot and cold.

Run ``python -m benchmarks.engine_path``. The model of section 9 (n = 4, p = 4, two
inputs) is fed as a node receives it (an input, then the measurements of its sample), for
three set-ups: one source without a history (the usual node), one source with a 0.5 s
history, two sources at 1 kHz each with a 0.5 s history; the stream prepares the next step
after each estimate, as the node does. Each event is timed alone, in a
tight loop (caches hot) and cold (about 1 ms of other work, touching an 8 MB array, between
events, as in place). The bare filter is then timed on the same rows (the updates the
stream made, recorded), so the engine's share is the stream's cost less the filter's.
Figures are per measurement (its input's cost included), medians.
"""

import argparse
import time

import numpy as np

from benchmarks.sources import estimator, events, MODEL, SECOND, source_set
from observer_ros.core.streaming import EventStream

#: The other work between events, cold: an 8 MB array, every cache line touched.
SCRATCH = np.zeros(1 << 20)


def other_work() -> None:
    """About a millisecond of other work that evicts the caches."""
    SCRATCH[::8] += 1.0


def recorded_updates(stream: EventStream) -> list:
    """Wrap the estimator's updates so that each one's arguments are kept (not timed)."""
    kept = []
    estimator = stream.estimator
    advance, advance_outputs = estimator.advance, estimator.advance_outputs

    def keep_advance(stamp, y, u):
        kept.append(('all', stamp, np.array(y), np.array(u), None))
        return advance(stamp, y, u)

    def keep_outputs(stamp, y, u, outputs):
        kept.append(('some', stamp, np.array(y), np.array(u), outputs))
        return advance_outputs(stamp, y, u, outputs)

    estimator.advance, estimator.advance_outputs = keep_advance, keep_outputs
    return kept


def feed(stream: EventStream, recorded: list, cold: bool) -> list:
    """Feed the events; return the seconds of each measurement (its inputs since included)."""
    clock = time.perf_counter
    costs, pending = [], 0.0
    for _, kind, stamp, values, source in recorded:
        if cold:
            other_work()
        values = values.tolist()
        started = clock()
        if kind == 0:
            stream.add_input(stamp, values)
            pending += clock() - started
        else:
            if stream.add_measurement(stamp, values, source=source):
                stream.prepare()  # as the node does once the estimate is out
            costs.append(clock() - started + pending)
            pending = 0.0
    return costs


def bare(filter_, updates: list, cold: bool) -> list:
    """Run the recorded updates on the filter alone; return the seconds of each."""
    clock = time.perf_counter
    costs = []
    for kind, stamp, y, u, outputs in updates:
        if cold:
            other_work()
        started = clock()
        if kind == 'all':
            filter_.advance(stamp, y, u)
        else:
            filter_.advance_outputs(stamp, y, u, outputs)
        costs.append(clock() - started)
    return costs


def measure(kind: str, sources: int, history_ns: int, seconds: float, cold: bool) -> tuple:
    """Return ``(stream us, filter us)`` per measurement, medians."""
    recorded = events(seconds, sources)
    options = {'history_ns': history_ns, 'sources': source_set(sources)}
    # A first pass makes the designs of every interval; the second is timed.
    stream = EventStream(estimator(kind), SECOND, **options)
    feed(stream, recorded, False)
    stream = EventStream(stream.estimator, SECOND, **options)
    stream.estimator.reset()
    costs = feed(stream, recorded, cold)
    stream = EventStream(stream.estimator, SECOND, **options)
    stream.estimator.reset()
    updates = recorded_updates(stream)
    feed(stream, recorded, False)
    filter_ = estimator(kind)
    bare(filter_, updates, False)  # the designs
    filter_.reset()
    filter_costs = bare(filter_, updates, cold)
    return np.median(costs) * 1e6, np.median(filter_costs) * 1e6


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[1])
    parser.add_argument('--seconds', type=float, default=1.0, help='of messages per set-up')
    options = parser.parse_args()
    print(f'n = {MODEL.n_states}, p = {MODEL.n_outputs}; us per measurement (median)')
    print(f'{"filter":22} {"set-up":28} {"loop":5} {"stream":>8} {"filter":>8} {"engine":>8}')
    for kind in ('time-varying Kalman', 'steady-state Kalman'):
        for sources, history in ((1, 0), (1, SECOND // 2), (2, SECOND // 2)):
            setup = f'{sources} source(s), history {history / SECOND:g} s'
            for cold in (False, True):
                stream, filter_ = measure(kind, sources, history, options.seconds, cold)
                print(f'{kind:22} {setup:28} {"cold" if cold else "hot":5} {stream:8.1f} '
                      f'{filter_:8.1f} {stream - filter_:8.1f}')


if __name__ == '__main__':
    main()
