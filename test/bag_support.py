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

"""Robot-style bags written with ``rosbags`` the way ``ros2 bag record`` lays them out."""

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import get_typestore, Stores
import yaml

from conftest import CONFIG_DIR
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.simulation import PlantSimulator

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
TYPES = TYPESTORE.types
JOINT_STATE = 'sensor_msgs/msg/JointState'
FLOAT64_MULTI_ARRAY = 'std_msgs/msg/Float64MultiArray'
STORAGES = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}
#: The robot's measurement and command topics.
ROBOT_TOPICS = ('/joint_states', '/effort_controller/commands')


def joint_state(stamp_ns, names, position, velocity=(), effort=(), frame_id=''):
    """Build a rosbags JointState."""
    stamp = TYPES['builtin_interfaces/msg/Time'](sec=int(stamp_ns // 10**9),
                                                 nanosec=int(stamp_ns % 10**9))
    return TYPES[JOINT_STATE](
        header=TYPES['std_msgs/msg/Header'](stamp=stamp, frame_id=frame_id), name=list(names),
        position=np.array(position, dtype=float), velocity=np.array(velocity, dtype=float),
        effort=np.array(effort, dtype=float))


def float64_array(values):
    """Build a rosbags Float64MultiArray."""
    layout = TYPES['std_msgs/msg/MultiArrayLayout'](dim=[], data_offset=0)
    return TYPES[FLOAT64_MULTI_ARRAY](layout=layout, data=np.array(values, dtype=float))


def serialize(message):
    """CDR bytes of a rosbags message."""
    return bytes(TYPESTORE.serialize_cdr(message, message.__msgtype__))


def robot_parameters(tmp_path):
    """Seed 003 plant measured as joint 'elbow' with a Float64MultiArray command topic."""
    params = yaml.safe_load((CONFIG_DIR / 'seed003_full_order.yaml').read_text())
    section = params['/**']['ros__parameters']
    section['model']['output_names'] = ['elbow']
    section['model']['input_names'] = ['elbow_effort']
    section['topics'] = {'u': {'type': 'float64_multi_array'}}
    path = tmp_path / 'robot.yaml'
    path.write_text(yaml.safe_dump(params))
    return path


#: Wall-clock start of the robot recordings (ns).
WALL_START_NS = 1_700_000_000 * 10**9


def write_robot_bag(path, samples=300, storage='mcap', topics=ROBOT_TOPICS,
                    stamp_start_ns=WALL_START_NS, log_start_ns=WALL_START_NS,
                    command_log_start_ns=None):
    """
    Record like ``ros2 bag record /joint_states /effort_controller/commands``.

    The joint states are stamped from ``stamp_start_ns`` on (``0``: simulation time), the
    recorder logs from ``log_start_ns`` (the commands from ``command_log_start_ns``, by
    default the same); the commands are unstamped. ``topics`` names the two topics
    (``joint_states`` without a slash, as some tools record).
    """
    params = validate_parameters(load_parameter_file(str(CONFIG_DIR /
                                                         'seed003_full_order.yaml')))
    plant = PlantSimulator(params.model, initial_state=[0.5, -0.5])
    rng = np.random.default_rng(3)
    truth = []
    if command_log_start_ns is None:
        command_log_start_ns = log_start_ns
    with Writer(path, version=9, storage_plugin=STORAGES[storage]) as writer:
        joints = writer.add_connection(topics[0], JOINT_STATE, typestore=TYPESTORE)
        commands = writer.add_connection(topics[1], FLOAT64_MULTI_ARRAY, typestore=TYPESTORE)
        for index in range(samples):
            stamp = stamp_start_ns + index * 10**7
            logged = log_start_ns + index * 10**7
            u = rng.uniform(-1.0, 1.0, size=1)
            y = plant.measure()
            truth.append(plant.x.copy())
            # The command in effect from this sample on was logged just before it.
            writer.write(commands, command_log_start_ns + index * 10**7 - 1000,
                         serialize(float64_array(u)))
            writer.write(joints, logged, serialize(joint_state(
                stamp, ['wrist', 'elbow', 'shoulder'], [0.1, y[0], -0.2], [0.0, 1.0, 2.0])))
            plant.step(u, 0.01)
    return np.array(truth)
