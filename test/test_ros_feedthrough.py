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
A closed loop with a feedthrough ``D != 0``: plant, observer and state feedback over DDS.

The plant simulator measures ``C x + D u`` with the input it applies at that sample and
publishes that ``u`` before ``y``; the observer takes ``D u`` off with the input in effect at
the measurement's stamp, so the estimate follows the state. The observer-controller gives
the pair's commands bit for bit, with the reported ``u`` and with its own commands taken as
the inputs (given before the measurement of the sample they are applied at).
"""

import numpy as np
import pytest

from golden_support import closed_loop_record, CONFIG_DIR
from ros_support import overrides

#: The seed's third-order plant with a direct path from u to y.
FEEDTHROUGH = 0.5


@pytest.fixture(scope='module')
def config(tmp_path_factory):
    text = (CONFIG_DIR / 'seed001_third_order.yaml').read_text()
    text = text.replace('      C: [1.0, 0.0, 0.0]\n',
                        f'      C: [1.0, 0.0, 0.0]\n      D: [{FEEDTHROUGH}]\n')
    assert f'D: [{FEEDTHROUGH}]' in text
    path = tmp_path_factory.mktemp('feedthrough') / 'seed001_feedthrough.yaml'
    path.write_text(text)
    return str(path)


@pytest.fixture(scope='module')
def pair(config):
    return closed_loop_record(config)


def test_the_estimate_follows_the_state_in_a_closed_loop_with_a_feedthrough(pair):
    x_true, x_hat = pair['x_true.values'], pair['x_hat.values']
    u, y = pair['u.values'], pair['y.values']
    np.testing.assert_allclose(y[:, 0], x_true[:, 0] + FEEDTHROUGH * u[:, 0], rtol=0,
                               atol=1e-12)  # y = C x + D u, u applied at that sample
    error = np.abs(x_hat[-50:] - x_true[-50:]).max()
    print(f'largest |x - x_hat| over the last 50 of {len(x_hat)} samples: {error:.2e}')
    assert error < 1e-6


@pytest.mark.parametrize('source', ['u', 'command'])
def test_the_controller_gives_the_pair_commands_with_a_feedthrough(config, pair, source):
    found = closed_loop_record(config, controller=True,
                               extra=overrides(controller__input=source))
    for key in ('u_cmd.values', 'x_hat.values', 'y.values'):
        assert found[key].tobytes() == pair[key].tobytes(), key
