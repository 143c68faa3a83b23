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
3. Offline replay throughput against ``control.forced_response``.

A bag of the seed 001 fourth-order plant (``y`` and ``u`` as JointState at 100 Hz) is
written once per storage; ``replay_bag`` reads, decodes and estimates (end to end), and the
estimator part alone (``EventStream.replay`` on the decoded arrays) is set against
``control.forced_response`` of the same discrete observer (its step matrix as an LTI
system) on the same data.
"""

from pathlib import Path
import tempfile

import control
import numpy as np

from benchmarks.common import CONFIG_DIR, pyplot, Section, timed
from observer_ros.bags.replay import replay_bag
from observer_ros.bags.replay_outputs import write_replay
from observer_ros.bags.storage import STORAGES
from observer_ros.bags.writing import TopicToWrite, write_bag
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.streaming import EventStream

PERIOD_NS = 10_000_000


def run(smoke: bool, figures) -> Section:
    """Measure and return the section."""
    samples = 20_000 if smoke else 1_000_000
    section = Section(3, 'Offline replay throughput', 'at least 100 000 samples per second '
                      'end to end at n = 4, and faster than control.forced_response on the '
                      'estimator part')
    system = validate_parameters(load_parameter_file(
        str(CONFIG_DIR / 'seed001_fourth_order.yaml')))
    rng = np.random.default_rng(0)
    stamps = np.arange(1, samples + 1, dtype=np.int64) * PERIOD_NS
    outputs = rng.standard_normal((samples, 1))
    inputs = rng.standard_normal((samples, 1))
    rates, rows = {}, []
    with tempfile.TemporaryDirectory() as scratch:
        for storage in STORAGES:
            bag = Path(scratch) / storage
            write_bag(bag, [
                TopicToWrite('/y', 'joint_state', 'position', ['y1'], stamps, stamps, outputs),
                TopicToWrite('/u', 'joint_state', 'position', ['u1'], stamps, stamps, inputs)],
                storage)
            result, seconds = timed(lambda: replay_bag(bag, system))
            assert len(result.estimates) == samples
            _, writing = timed(lambda: write_replay(
                result, str(Path(scratch) / f'{storage}_x_hat'), storage=storage,
                innovation=False))
            rates[f'replay, {storage}'] = samples / seconds
            rows.append([f'`replay_bag` ({storage}): read, decode, estimate', f'{seconds:.2f}',
                         f'{samples / seconds:,.0f}'])
            rows.append([f'... and write the x_hat bag ({storage})',
                         f'{seconds + writing:.2f}', f'{samples / (seconds + writing):,.0f}'])
    stream = EventStream(system.observer.make_estimator(), int(1e9))
    replayed, ours = timed(lambda: stream.replay(stamps, inputs, stamps, outputs))
    rates['estimator part'] = samples / ours
    step = stream.estimator.last_step.g
    n = system.model.n_states
    lti = control.ss(step[:n, :n], step[:n, n:], np.eye(n), np.zeros((n, step.shape[1] - n)),
                     PERIOD_NS / 1e9)
    # Row k of the input drives x_hat[k] -> x_hat[k+1]: u held before sample k+1 and y[k+1].
    drive = np.vstack([np.hstack([inputs[:-1], outputs[1:]]).T])
    first = replayed.estimates[0]
    response, theirs = timed(lambda: control.forced_response(
        lti, np.arange(samples - 1) * PERIOD_NS / 1e9, drive, X0=first,
        return_x=True))
    rates['control.forced_response'] = samples / theirs
    difference = np.abs(response.states[:, -1] - replayed.estimates[-2]).max()
    rows.append(['estimator part: `EventStream.replay` on arrays', f'{ours:.2f}',
                 f'{samples / ours:,.0f}'])
    rows.append(['`control.forced_response`, same observer and data', f'{theirs:.2f}',
                 f'{samples / theirs:,.0f}'])
    section.add(f'{samples:,} samples, n = 4 (seed 001 fourth-order plant, reduced-order '
                'observer), inputs and outputs random. forced_response agrees with the replay '
                f'to {difference:.1e} (same arithmetic, other order).', '')
    section.table(['path', 'seconds', 'samples / s'], rows)
    section.add(f'Estimator part: {ours and theirs / ours:.2f}x the speed of '
                'control.forced_response. The rest of the end-to-end time is reading the bag '
                "(MCAP: the package's one-pass reader; sqlite3: `rosbags`) and the CDR "
                'decoding.', '')
    section.met = (min(rates['replay, mcap'], rates['replay, sqlite3']) >= 100_000
                   and rates['estimator part'] > rates['control.forced_response'])
    plt = pyplot()
    figure, axis = plt.subplots(figsize=(7, 3.5))
    names = list(rates)
    axis.barh(names, [rates[name] for name in names], color=['C0', 'C0', 'C2', 'C3'])
    axis.axvline(100_000, color='k', linestyle='--', label='goal (end to end)')
    axis.set_xlabel('samples per second')
    axis.legend()
    section.figures.append(figures.save(figure, 'replay_throughput'))
    return section
