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
``observer_controller``: the observer and the state feedback in one node and one callback.

The lockstep closed loop of the plant and the controller records the same topics as the
plant, observer and state feedback do (the goldens of ``test_golden_outputs.py``, which hold
the pair), bit for bit, for every shipped config with a feedback: the same commands, the
same estimates. With ``controller.input: command`` (no ``u`` topic) the commands are the same
too, since the plant applies what the controller sent from the next sample on.
"""

import pytest

from golden_support import (
    assert_records_equal, CLOSED_LOOP_CONFIGS, closed_loop_record, GOLDEN_DIR, pair_record)
from observer_ros.config import CONTROLLER, FEEDBACK, node_parameters, OBSERVER
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.nodes.observer_controller import ObserverControllerNode
from ros_support import overrides, ros_context

CONFIG_DIR = GOLDEN_DIR.parents[1] / 'config'


@pytest.mark.parametrize('config', CLOSED_LOOP_CONFIGS)
def test_the_controller_commands_equal_the_pair_bit_for_bit(config):
    # Both run here: one machine computing the same loop twice is equal to the last bit on
    # any machine (the pair is also held to its golden, within tolerance, elsewhere).
    assert_records_equal(closed_loop_record(config, controller=True), pair_record(config))


@pytest.mark.parametrize('config', ['seed003_full_order.yaml', 'robot_joint.yaml'])
def test_commands_taken_as_inputs_equal_the_reported_inputs(config):
    # No u topic: the controller takes the command it sent as the input applied from the
    # next sample on, which is what the plant reports on u; so nothing changes.
    pair = pair_record(config)
    found = closed_loop_record(config, controller=True,
                               extra=overrides(controller__input='command'))
    for key in ('u_cmd.values', 'x_hat.values', 'y.values'):
        assert found[key].tobytes() == pair[key].tobytes(), key


def test_the_controller_declares_what_the_two_nodes_declare():
    declared = {spec.name for spec in node_parameters(CONTROLLER)}
    both = ({spec.name for spec in node_parameters(OBSERVER)}
            | {spec.name for spec in node_parameters(FEEDBACK)})
    assert declared == both | {'controller.input'}
    system = validate_parameters(load_parameter_file(str(CONFIG_DIR / 'robot_joint.yaml')),
                                 node=CONTROLLER)
    assert system.observer is not None and system.feedback is not None
    assert system.plant is None and system.loop.closed_loop_poles is not None


def test_the_closed_loop_poles_are_logged_and_on_the_diagnostics(capfd):
    path = CONFIG_DIR / 'seed003_full_order.yaml'
    with ros_context('--params-file', str(path)) as context:
        capfd.readouterr()
        node = ObserverControllerNode(context=context)
        try:
            logged = [line for line in capfd.readouterr().err.splitlines()
                      if '[observer_controller]: closed loop: ' in line]
            assert len(logged) == 1 and logged[0].endswith(
                'A - B K poles [-3-3j, -3+3j], observer poles [-8-6j, -8+6j]; together '
                '[-8-6j, -8+6j, -3-3j, -3+3j]'), logged
            values = dict(node.health.configuration().values)
            loop = node.system.loop.closed_loop_poles
            assert len(loop) == (node.system.model.n_states
                                 + len(node.system.observer.design.achieved_poles))
            for key in ('observer_poles', 'feedback_poles', 'closed_loop_poles'):
                assert key in values, key
            assert node.subscribes_input(node.system)
        finally:
            node.destroy_node()
