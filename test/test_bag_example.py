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
How to test an observer against a recorded bag (the example README shows).

Replace the fixture with the path of your own recording (``ros2 bag record /joint_states
/my_controller/commands``, or ``closed_loop --record``) and your parameter file.
"""

import numpy as np
import pytest

from conftest import CONFIG_DIR
from observer_ros.bags.replay import replay_bag
from ros_support import run_lockstep

PARAMETERS = CONFIG_DIR / 'seed001_third_order.yaml'


@pytest.fixture(scope='module')
def recorded_bag(tmp_path_factory):
    """Record a closed-loop run (your robot's bag in real use)."""
    bag = tmp_path_factory.mktemp('bags') / 'run'
    run_lockstep(PARAMETERS.name, samples=200, bag=bag)
    return bag


def test_observer_converges_on_the_recording(recorded_bag):
    result = replay_bag(recorded_bag, PARAMETERS)
    assert result.counters['malformed'] == 0
    assert np.all(np.isfinite(result.estimates))
    errors = result.error_norms()              # against /x_true in the bag
    assert errors[-1] < 1e-6 * errors[0]       # designed poles -10: e^-20 after 2 s
