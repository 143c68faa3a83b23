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
``closed_loop`` with the observer-controller: what it records and what it takes as inputs.

The recording has every sample's estimate, with the pair and with the controller; commands
taken as inputs equal the reported inputs only with the same safe input in plant and
controller.
"""

import pytest

from conftest import CONFIG_DIR, REPOSITORY
from observer_ros.nodes.closed_loop import ClosedLoop
from observer_ros.ros.executors import make_executor
from ros_support import overrides, patient_lockstep, ros_context

SAMPLES = 40


@pytest.mark.parametrize('controller', [False, True])
def test_the_recorder_has_the_estimate_of_every_sample(controller):
    # The controller publishes the last command, which ends the run, before the last
    # estimate: the recording used to stop one x_hat short of the pair's (with the events
    # executor, closed_loop's default).
    config = CONFIG_DIR / 'seed003_full_order.yaml'
    with ros_context('--params-file', str(config)) as context:
        loop = ClosedLoop(record=True, context=context, controller=controller,
                          executor=make_executor('events', context),
                          overrides=overrides(plant__lockstep=True, plant__samples=SAMPLES)
                          + patient_lockstep())
        try:
            assert loop.spin(timeout_sec=120.0)
            x_hat, _ = loop.recorder.arrays('x_hat')
            y, _ = loop.recorder.arrays('y')
        finally:
            loop.destroy()
    period = loop.plant.period_ns
    assert y.tolist() == [(k + 1) * period for k in range(SAMPLES)]
    assert x_hat.tolist() == y.tolist()


def commands(controller_input: str, safe_input: float) -> list:
    config = CONFIG_DIR / 'seed003_full_order.yaml'
    with ros_context('--params-file', str(config)) as context:
        loop = ClosedLoop(record=True, context=context, controller=True,
                          executor=make_executor('events', context),
                          overrides=overrides(plant__lockstep=True, plant__samples=SAMPLES,
                                              plant__safe_input=[safe_input],
                                              controller__input=controller_input)
                          + patient_lockstep())
        try:
            assert loop.spin(timeout_sec=120.0)
            return loop.recorder.arrays('u_cmd')[1].ravel().tolist()
        finally:
            loop.destroy()


def test_commands_as_inputs_equal_the_reported_ones_only_with_the_same_safe_input():
    # Before its first command the plant applies plant.safe_input, while the controller
    # with controller.input: command takes feedback.safe_command (zero here): the two agree
    # only when these are equal, which doc/observer_controller.md now says.
    assert commands('command', 0.0) == commands('u', 0.0)
    assert commands('command', 0.3) != commands('u', 0.3)
    page = (REPOSITORY / 'doc' / 'observer_controller.md').read_text(encoding='utf-8')
    assert 'only when `plant.safe_input` equals `feedback.safe_command`' in ' '.join(
        page.split())
