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
The lean path from a measurement to the first publish (issue 29), in the observer part.

The step prepared once per sample and taken without the engine's arrays (the fused path)
gives the bytes the general path gives, bit for bit; the secondary topics are neither
encoded nor published while nobody subscribes them, and are once a subscription matches.
"""

from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState

from conftest import CONFIG_DIR
from observer_ros.nodes.observer import ObserverNode
from observer_ros.nodes.observer_controller import ObserverControllerNode
from observer_ros.ros.messages import ns_to_stamp
from ros_support import executor_with, ros_context, spin_until

#: The latency benchmark's observer (seed 001, fourth order, one output).
CONFIG = CONFIG_DIR / 'seed001_fourth_order.yaml'

#: The benchmark's controller: its commands are the inputs of the next prediction.
CONTROLLER = [Parameter('controller.input', value='command'),
              Parameter('feedback.poles', value=['-2+1j', '-2-1j', '-3', '-4'])]

STEP_NS = 10_000_000


def message(name: str, stamp: int, value: float) -> bytes:
    """Return a serialized one-joint JointState stamped ``stamp``."""
    joint_state = JointState(name=[name], position=[value])
    ns_to_stamp(joint_state.header.stamp, stamp)
    return serialize_message(joint_state)


def callbacks(node) -> dict:
    """Return the node's subscription callbacks by topic name."""
    return {s.topic_name.rsplit('/', 1)[-1]: s.callback for s in node.subscriptions}


def recorded(publisher, into: list) -> None:
    """Record what ``publisher`` publishes (the serialized bytes) instead of sending it."""
    publisher.publish = into.append


def run(node_class, extra: list, general: bool, count: int = 300) -> tuple:
    """
    Feed ``count`` measurements (and the observer's inputs) through the node's callbacks.

    Return the bytes published on the answer topic and on ``x_hat``, and the number of
    steps the stream took on its prepared path. ``general``: the stream never prepares a
    step, so every measurement takes the engine's general path.
    """
    with ros_context('--params-file', str(CONFIG)) as context:
        node = node_class(context=context, parameter_overrides=extra)
        try:
            part = node.observer_part
            if general:
                part.stream.prepare = lambda: None
            estimator, prepared = part.stream.estimator, []
            advance_prepared = estimator.advance_prepared

            def counted(*args):
                result = advance_prepared(*args)
                prepared.append(result is not None)
                return result
            estimator.advance_prepared = counted
            prepare, preparations = estimator.prepare, []
            estimator.prepare = lambda *args: preparations.append(1) or prepare(*args)
            x_hat, commands = [], []
            recorded(part.x_hat_publisher, x_hat)
            part.listened['x_hat'] = True  # as when something subscribes x_hat
            if hasattr(node, 'feedback_part'):
                recorded(node.feedback_part.publisher, commands)
            on = callbacks(node)
            for k in range(count):
                stamp = (k + 1) * STEP_NS
                on['y'](message('y1', stamp, 0.01 * (k % 7)))
                if 'u' in on:
                    on['u'](message('u1', stamp, 0.1 * (k % 3)))
            assert len(preparations) <= count  # the step prepared once per sample at most
            return commands, x_hat, sum(prepared)
        finally:
            node.destroy_node()


def test_the_observer_s_fused_path_publishes_the_general_path_s_bytes():
    fused, x_hat, steady = run(ObserverNode, [], general=False)
    _, general_x_hat, general_steady = run(ObserverNode, [], general=True)
    assert steady > 250 and general_steady == 0  # the paths taken are the two compared
    assert len(x_hat) == 300 and x_hat == general_x_hat


def test_the_controller_s_fused_path_publishes_the_general_path_s_commands():
    commands, x_hat, steady = run(ObserverControllerNode, CONTROLLER, general=False)
    general, general_x_hat, general_steady = run(ObserverControllerNode, CONTROLLER,
                                                 general=True)
    assert steady > 250 and general_steady == 0
    assert len(commands) > 250 and commands == general  # a few estimates reset (no plant)
    assert x_hat == general_x_hat


def test_secondary_topics_are_published_only_while_subscribed():
    # Before, innovation was encoded and published for every estimate, subscribed or not.
    with ros_context('--params-file', str(CONFIG)) as context:
        observer = ObserverNode(context=context)
        driver = Node('lean_driver', context=context)
        part = observer.observer_part
        innovations, x_hat = [], []
        publisher = part.publishers_['innovation']
        send = publisher.publish
        publisher.publish = lambda data: innovations.append(data) or send(data)
        recorded(part.x_hat_publisher, x_hat)
        on_y = callbacks(observer)['y']
        on_u = callbacks(observer)['u']
        with executor_with(context, observer, driver) as executor:
            for k in range(20):
                on_y(message('y1', (k + 1) * STEP_NS, 0.1))
                on_u(message('u1', (k + 1) * STEP_NS, 0.0))
            assert len(x_hat) == 20 and innovations == []  # x_hat: the node's answer
            assert len(part.health.innovations) == 20  # the health still takes them
            received = []
            driver.create_subscription(JointState, 'innovation', received.append, 100)
            assert spin_until(executor, lambda: part.listened['innovation'], 10.0)
            for k in range(20, 30):
                on_y(message('y1', (k + 1) * STEP_NS, 0.1))
                on_u(message('u1', (k + 1) * STEP_NS, 0.0))
            assert len(innovations) == 10
            assert spin_until(executor, lambda: len(received) == 10, 10.0)
