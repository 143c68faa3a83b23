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
Check whether a plain rclpy listener in another process keeps receiving (no package code).

``python -m benchmarks.dds_stall [runs]`` starts, per run, a listener process and a second
later a talker process publishing a JointState at 250 Hz for 4 s, and prints how many the
listener received. On the machines the benchmarks ran on, some runs stop at about 1.3 s
after the talker starts (about 330 of 1000 messages) with reliable or best-effort QoS and
with shared-memory or UDP transport: the separate-process rows of benchmark 5 vary with it.
"""

import os
import subprocess
import sys
import time

TALKER = """
import rclpy
from rclpy.node import Node
from sensor_msgs.msg import JointState
rclpy.init()
node = Node('stall_talker')
publisher = node.create_publisher(JointState, 'stall_topic', 10)
count = [0]
def tick():
    count[0] += 1
    publisher.publish(JointState(name=['a'], position=[float(count[0])]))
node.create_timer(0.004, tick)
while count[0] < 1000:
    rclpy.spin_once(node, timeout_sec=0.1)
"""

LISTENER = """
import time
import rclpy
from rclpy.node import Node
from sensor_msgs.msg import JointState
rclpy.init()
node = Node('stall_listener')
count = [0]
node.create_subscription(JointState, 'stall_topic', lambda m: count.__setitem__(0, count[0] + 1),
                         10)
end = time.monotonic() + 7.0
while time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.1)
print(count[0])
"""


def run(runs: int) -> list:
    """Return the number of messages (of 1000) the listener received, per run."""
    counts = []
    for _ in range(runs):
        listener = subprocess.Popen([sys.executable, '-c', LISTENER], stdout=subprocess.PIPE,
                                    stderr=subprocess.DEVNULL, text=True)
        time.sleep(1.0)
        talker = subprocess.Popen([sys.executable, '-c', TALKER], stderr=subprocess.DEVNULL)
        out, _ = listener.communicate(timeout=30)
        talker.wait(timeout=30)
        counts.append(int(out.strip() or 0))
    return counts


def main() -> int:
    """Print the counts of ``argv[1]`` runs (default 6)."""
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    counts = run(int(sys.argv[1]) if len(sys.argv) > 1 else 6)
    print('messages received of 1000, per run:', ' '.join(map(str, counts)))
    return 0


if __name__ == '__main__':
    sys.exit(main())
