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
The golden outputs (see ``golden_support``) are reproduced bit for bit.

Design JSON of every shipped config, the lockstep closed-loop record of every config with
a feedback (P and NIS included for the Kalman filters), and replays of committed bags for
every config and the models without inputs.
"""

import json

import numpy as np
import pytest

from conftest import console_script
from golden_support import (
    assert_records_equal, CLOSED_LOOP_CONFIGS, closed_loop_record, design_json, GOLDEN_DIR,
    load_npz, replay_cases, replay_record, SHIPPED_CONFIGS)


@pytest.mark.parametrize('config', SHIPPED_CONFIGS)
def test_design_json_equals_the_golden(config):
    golden = json.loads((GOLDEN_DIR / 'design' / config.replace('.yaml', '.json')).read_text())
    assert design_json(config, console_script('design_observer')) == golden


@pytest.mark.parametrize('case', replay_cases())
def test_replay_equals_the_golden(case):
    golden = load_npz(GOLDEN_DIR / 'replay' / case.replace('.yaml', '.npz'))
    assert_records_equal(replay_record(case), golden)


@pytest.mark.parametrize('config', CLOSED_LOOP_CONFIGS)
def test_lockstep_closed_loop_equals_the_golden(config):
    golden = load_npz(GOLDEN_DIR / 'closed_loop' / config.replace('.yaml', '.npz'))
    assert_records_equal(closed_loop_record(config), golden)


def test_the_golden_set_covers_every_observer_type_and_the_special_models():
    kinds = set()
    for case in replay_cases():
        record = load_npz(GOLDEN_DIR / 'replay' / case.replace('.yaml', '.npz'))
        assert len(record['stamps']) > 250, case
        assert np.all(np.isfinite(record['estimates'])), case
    for config in SHIPPED_CONFIGS:
        summary = json.loads((GOLDEN_DIR / 'design' / config.replace('.yaml', '.json'))
                             .read_text())
        kinds.add(summary['observer.type'])
    assert {'full_order', 'reduced_order', 'chen', 'kalman'} <= kinds
    # The time-varying filter and the Kalman closed loops carry P and NIS.
    record = load_npz(GOLDEN_DIR / 'closed_loop' / 'kalman_time_varying.npz')
    assert record['x_hat_covariance.values'].shape[0] >= 199
    assert record['nis.values'].shape[0] >= 199
