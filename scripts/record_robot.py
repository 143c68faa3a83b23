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
Write a robot-like rosbag2 bag with jittered stamps: the walkthrough's recording.

A differential-drive base (doc/walkthrough.md) under a closed velocity loop: a random
velocity reference ``[v_ref, w_ref]``, a new one with every ``--command-every``-th sample,
and before each sample but the first a command on ``/cmd_vel`` (``geometry_msgs/Twist``,
unstamped) computed from the latest sample's measured (noisy) speeds and the reference
(the base is at rest, with no command, until the controller has a measurement),
``v_cmd = v_ref + k (v_ref - v_meas)`` and ``w_cmd = w_ref + k (w_ref - w_meas)``, with
``k`` the ``--gain`` (0 sends the reference as it is), ``v_meas`` the mean of the wheel
velocities over 10 and ``w_meas`` the gyro. The command is sent 1 ms before the next
sample (a controller synchronised with the driver), so that sample sees it. The base's
speed ``v`` and turn rate ``w`` follow the commanded ones with a time constant of 0.2 s,
``v' = 5 (v_cmd - v)``, ``w' = 5 (w_cmd - w)``, plus white process noise. One driver
samples, at ``--rate`` Hz with each stamp off its period by up to ``--jitter`` seconds
(uniformly), the wheels on ``/joint_states`` (``sensor_msgs/JointState``: position and
velocity of ``left_wheel_joint`` and ``right_wheel_joint``, radius 0.1 m, 0.4 m apart:
``10 v -+ 2 w`` rad/s) and an IMU on ``/imu/data`` (``sensor_msgs/Imu``:
``linear_acceleration.x = v' = 5 v_cmd - 5 v`` and ``angular_velocity.z = w``), both with
the same stamp and white measurement noise. The accelerometer sees the command directly:
its row of the feedthrough ``D`` is ``[5, 0]``. The motion is simulated exactly between
events (a command, a sample). The messages are logged as a recorder logs them: the
commands when sent, the sensors 0.3 ms after their stamps.
"""

import argparse
import math
from pathlib import Path
import sys

import numpy as np
from rosbags.rosbag2 import StoragePlugin, Writer
from rosbags.typesys import get_typestore, Stores

#: The base's time constant is 1 / RESPONSE seconds.
RESPONSE = 5.0
#: Wheel velocity (rad/s) per m/s of forward speed and per rad/s of turn rate.
WHEEL_PER_SPEED, WHEEL_PER_TURN = 10.0, 2.0
#: Standard deviations of the sensors' noise: wheel velocity (rad/s), acceleration (m/s^2),
#: turn rate (rad/s).
WHEEL_NOISE, ACCEL_NOISE, GYRO_NOISE = 0.05, 0.05, 0.01
#: Intensity of the process noise on v and w ((m/s)^2/s, (rad/s)^2/s).
PROCESS_NOISE = (0.002, 0.008)
#: The largest commands (m/s, rad/s).
SPEED_LIMIT, TURN_LIMIT = 0.5, 1.0
#: How long after its stamp the recorder logs a sensor message (ns).
LOG_DELAY_NS = 300_000
#: How long before the next sample a command is sent (ns).
COMMAND_LEAD_NS = 1_000_000
#: Where the recording starts (ns since the epoch).
START_NS = 1_700_000_000 * 10**9
NS = 10**9
STORAGES = {'mcap': StoragePlugin.MCAP, 'sqlite3': StoragePlugin.SQLITE3}


def parse_arguments(argv):
    """Parse the command line; errors exit with status 2 naming the option."""
    parser = argparse.ArgumentParser(description=__doc__.strip().splitlines()[0])
    parser.add_argument('bag', help='the bag directory to write (must not exist)')
    parser.add_argument('--seconds', type=float, default=40.0, help='duration (default 40)')
    parser.add_argument('--rate', type=float, default=50.0,
                        help='sensor rate in Hz (default 50)')
    parser.add_argument('--jitter', type=float, default=0.003,
                        help='largest offset of a stamp from its period, s (default 0.003)')
    parser.add_argument('--command-every', type=int, default=20,
                        help='samples between changes of the reference (default 20)')
    parser.add_argument('--gain', type=float, default=1.0,
                        help='feedback gain k of the velocity loop, v_cmd = v_ref + '
                             'k (v_ref - v_meas); 0 sends the reference (default 1)')
    parser.add_argument('--seed', type=int, default=0, help='random seed (default 0)')
    parser.add_argument('--storage', choices=STORAGES, default='mcap',
                        help='bag storage (default mcap)')
    arguments = parser.parse_args(argv)
    for name in ('seconds', 'rate', 'command_every'):
        if not getattr(arguments, name) > 0.0:
            parser.error(f'--{name.replace("_", "-")}: expected a positive number, got '
                         f'{getattr(arguments, name)}')
    if not (math.isfinite(arguments.gain) and arguments.gain >= 0.0):
        parser.error(f'--gain: expected a finite number >= 0, got {arguments.gain}')
    period = 1.0 / arguments.rate
    if not 0.0 <= arguments.jitter < period / 2:
        parser.error(f'--jitter: expected 0 <= jitter < half the period ({period / 2:g} s), '
                     f'got {arguments.jitter}')
    if Path(arguments.bag).exists():
        parser.error(f'bag: {arguments.bag} exists already; choose a new path')
    return arguments


def simulate(arguments):
    """
    Simulate the base under its velocity loop; return the commands and the samples.

    Returns
    -------
    commands : list of (int, ndarray)
        Send time (ns) and ``[v_cmd, w_cmd]`` of each command, one before each sample
        but the first.
    samples : list of (int, ndarray, ndarray, ndarray)
        Stamp (ns), wheel positions, wheel velocities ``(2,)`` and ``[accel_x, gyro_z]``.

    """
    rng = np.random.default_rng(arguments.seed)
    period_ns = round(NS / arguments.rate)
    count = int(arguments.seconds * arguments.rate)
    jitter_ns = round(arguments.jitter * NS)
    stamps = [k * period_ns + int(rng.integers(-jitter_ns, jitter_ns + 1)) if k else 0
              for k in range(count)]
    references = [rng.uniform([-SPEED_LIMIT, -TURN_LIMIT], [SPEED_LIMIT, TURN_LIMIT])
                  for _ in range(0, count, arguments.command_every)]
    mix = np.array([[WHEEL_PER_SPEED, -WHEEL_PER_TURN], [WHEEL_PER_SPEED, WHEEL_PER_TURN]])
    state, wheel_angle, command = np.zeros(2), np.zeros(2), np.zeros(2)
    time_ns = 0

    def advance(event_ns):
        # The motion under the held command, exact over the step, then the process noise.
        nonlocal state, time_ns
        step = (event_ns - time_ns) / NS
        if step <= 0.0:
            return
        decay = math.exp(-RESPONSE * step)
        start = state.copy()
        state = decay * state + (1.0 - decay) * command
        # The wheel angle integrates the wheel velocity exactly over the step.
        mean = command * step + (start - command) * (1.0 - decay) / RESPONSE
        wheel_angle[:] += mix @ mean
        state = state + rng.normal(0.0, np.sqrt(np.array(PROCESS_NOISE) * step))
        time_ns = event_ns

    commands, samples = [], []
    for index, stamp_ns in enumerate(stamps):
        advance(stamp_ns)
        wheels = mix @ state + rng.normal(0.0, WHEEL_NOISE, 2)
        imu = (np.array([RESPONSE * (command[0] - state[0]), state[1]])
               + rng.normal(0.0, [ACCEL_NOISE, GYRO_NOISE]))
        samples.append((START_NS + stamp_ns, wheel_angle.copy(), wheels, imu))
        if index + 1 == count:
            break  # the recording ends with this sample; no command is sent after it
        # The controller: the reference against this sample's measured speeds, sent for the
        # next sample.
        reference = references[index // arguments.command_every]
        measured = np.array([np.mean(wheels) / WHEEL_PER_SPEED, imu[1]])
        sent_ns = stamps[index + 1] - COMMAND_LEAD_NS
        advance(sent_ns)
        command = reference + arguments.gain * (reference - measured)
        commands.append((START_NS + sent_ns, command))
    return commands, samples


def write(arguments, commands, samples):
    """Write the recording to ``arguments.bag``."""
    store = get_typestore(Stores.ROS2_JAZZY)
    types = store.types

    def header(stamp_ns, frame):
        stamp = types['builtin_interfaces/msg/Time'](sec=stamp_ns // NS, nanosec=stamp_ns % NS)
        return types['std_msgs/msg/Header'](stamp=stamp, frame_id=frame)

    def vector(x=0.0, y=0.0, z=0.0):
        return types['geometry_msgs/msg/Vector3'](x=float(x), y=float(y), z=float(z))

    def cdr(message):
        return bytes(store.serialize_cdr(message, message.__msgtype__))

    unknown = np.zeros(9)
    unknown[0] = -1.0  # no orientation, as an IMU without a filter reports it
    messages = []
    for sent_ns, (speed, turn) in commands:
        messages.append((sent_ns, '/cmd_vel', cdr(types['geometry_msgs/msg/Twist'](
            linear=vector(x=speed), angular=vector(z=turn)))))
    for stamp_ns, position, velocity, (accel, gyro) in samples:
        messages.append((stamp_ns + LOG_DELAY_NS, '/joint_states',
                         cdr(types['sensor_msgs/msg/JointState'](
                             header=header(stamp_ns, ''),
                             name=['left_wheel_joint', 'right_wheel_joint'],
                             position=position, velocity=velocity,
                             effort=np.zeros(0)))))
        messages.append((stamp_ns + LOG_DELAY_NS, '/imu/data', cdr(types['sensor_msgs/msg/Imu'](
            header=header(stamp_ns, 'imu_link'),
            orientation=types['geometry_msgs/msg/Quaternion'](x=0.0, y=0.0, z=0.0, w=1.0),
            orientation_covariance=unknown, angular_velocity=vector(z=gyro),
            angular_velocity_covariance=np.zeros(9), linear_acceleration=vector(x=accel),
            linear_acceleration_covariance=np.zeros(9)))))
    kinds = {'/cmd_vel': 'geometry_msgs/msg/Twist', '/joint_states': 'sensor_msgs/msg/JointState',
             '/imu/data': 'sensor_msgs/msg/Imu'}
    with Writer(Path(arguments.bag), version=9,
                storage_plugin=STORAGES[arguments.storage]) as writer:
        connections = {topic: writer.add_connection(topic, kind, typestore=store)
                       for topic, kind in kinds.items()}
        for logged_ns, topic, raw in sorted(messages, key=lambda item: item[0]):
            writer.write(connections[topic], logged_ns, raw)


def main(argv=None):
    """Record the base; print what was written."""
    arguments = parse_arguments(sys.argv[1:] if argv is None else argv)
    commands, samples = simulate(arguments)
    write(arguments, commands, samples)
    intervals = np.diff([sample[0] for sample in samples]) / 1e6
    print(f'{arguments.bag}: {len(samples)} samples of /joint_states and /imu/data, '
          f'{len(commands)} commands on /cmd_vel; sample intervals {intervals.min():.1f} to '
          f'{intervals.max():.1f} ms')
    return 0


if __name__ == '__main__':
    sys.exit(main())
