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
How long two processes take to discover each other (plain rclpy, no package code).

``python -m benchmarks.discovery [--runs N] [--stagger S]`` starts, per run, a listener
process and ``S`` seconds later (default 1) a talker that publishes a JointState at 250 Hz
for 4 s from the moment it is up, without waiting for anything (reliable, a history of
1000 both sides: nothing is lost to a full queue). Both note, on the
system-wide monotonic clock, when their endpoint is matched (``get_subscription_count`` /
``get_publisher_count``) and the listener when the first message arrives and how many
follow. Printed per configuration, in seconds after the talker process started: when the
talker's node was up, when each side matched, when the first message arrived, how many runs
took more than a second, and how many messages went missing after the first one.

Every configuration keeps ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``. ``SUBNET`` is not
measured: it announces by multicast on every interface, so off this machine.
"""

import argparse
import json
import os
from pathlib import Path
import statistics
import subprocess
import sys
import tempfile
import time

from benchmarks.common import CONFIG_DIR

#: The shipped Fast DDS profile (announcement period 0.5 s instead of 3 s).
PROFILE = CONFIG_DIR / 'fastdds_discovery.xml'

#: Messages the talker publishes, and their period (s).
MESSAGES = 1000
PERIOD = 0.004

#: A run counts as slow when the first message arrives later than this after the talker
#: node is up (s).
SLOW = 1.0

TALKER = r"""
import json, sys, time
import rclpy
from rclpy.node import Node
from sensor_msgs.msg import JointState
rclpy.init()
node = Node('discovery_talker')
publisher = node.create_publisher(JointState, 'discovery_topic', 1000)
ready = time.monotonic()
matched = [None]
sent = [0]
def tick():
    if matched[0] is None and publisher.get_subscription_count() > 0:
        matched[0] = time.monotonic()
    if sent[0] < int(sys.argv[1]):
        sent[0] += 1
        publisher.publish(JointState(name=['a'], position=[float(sent[0])]))
node.create_timer(float(sys.argv[2]), tick)
while sent[0] < int(sys.argv[1]):
    rclpy.spin_once(node, timeout_sec=0.05)
print(json.dumps({'ready': ready, 'matched': matched[0], 'sent': sent[0]}))
"""

LISTENER = r"""
import json, sys, time
import rclpy
from rclpy.node import Node
from sensor_msgs.msg import JointState
rclpy.init()
node = Node('discovery_listener')
arrivals = []
subscription = node.create_subscription(
    JointState, 'discovery_topic',
    lambda m: arrivals.append((time.monotonic(), int(m.position[0]))), 1000)
ready = time.monotonic()
matched = None
end = ready + float(sys.argv[1])
while time.monotonic() < end:
    rclpy.spin_once(node, timeout_sec=0.005)
    if matched is None and subscription.get_publisher_count() > 0:
        matched = time.monotonic()
indices = [index for _, index in arrivals]
print(json.dumps({'ready': ready, 'matched': matched,
                  'first': arrivals[0][0] if arrivals else None,
                  'first_index': indices[0] if indices else None,
                  'received': len(indices),
                  'missing_after_first': (indices[-1] - indices[0] + 1 - len(indices))
                  if indices else None}))
"""

#: Fast DDS profile with 20 initial announcements (2 s) instead of 5 (0.5 s).
INITIAL_ANNOUNCEMENTS = """<?xml version="1.0" encoding="UTF-8" ?>
<profiles xmlns="http://www.eprosima.com/XMLSchemas/fastRTPS_Profiles">
  <participant profile_name="initial_announcements" is_default_profile="true">
    <rtps><builtin><discovery_config>
      <initialAnnouncements><count>20</count>
        <period><sec>0</sec><nanosec>100000000</nanosec></period></initialAnnouncements>
    </discovery_config></builtin></rtps>
  </participant>
</profiles>
"""


def configurations(scratch: Path) -> list:
    """``(label, environment, factor of --stagger)`` of every measured configuration."""
    initial = scratch / 'initial_announcements.xml'
    initial.write_text(INITIAL_ANNOUNCEMENTS, encoding='utf-8')
    return [
        ('defaults', {}, 1.0),
        ('defaults', {}, 0.0),
        ('ROS_STATIC_PEERS=127.0.0.1', {'ROS_STATIC_PEERS': '127.0.0.1'}, 1.0),
        ('20 initial announcements at 100 ms (profile)',
         {'FASTRTPS_DEFAULT_PROFILES_FILE': str(initial)}, 1.0),
        ('20 initial announcements at 100 ms (profile)',
         {'FASTRTPS_DEFAULT_PROFILES_FILE': str(initial)}, 3.0),
        (f'announcement period 0.5 s (config/{PROFILE.name})',
         {'FASTRTPS_DEFAULT_PROFILES_FILE': str(PROFILE)}, 1.0),
    ]


def one_run(environment: dict, stagger: float) -> dict:
    """Start the listener, then the talker ``stagger`` s later; times after the talker start."""
    env = dict(os.environ, ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST', **environment)
    talking = MESSAGES * PERIOD
    listener = subprocess.Popen(
        [sys.executable, '-c', LISTENER, str(stagger + talking + 3.0)],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    talker = None
    try:
        time.sleep(stagger)  # the stagger is what is measured, not a wait for readiness
        started = time.monotonic()
        talker = subprocess.Popen([sys.executable, '-c', TALKER, str(MESSAGES), str(PERIOD)],
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                  env=env)
        talked, talker_err = talker.communicate(timeout=talking + 60)
        heard, listener_err = listener.communicate(timeout=stagger + talking + 60)
    finally:
        for process in (listener, talker):
            if process is not None and process.poll() is None:
                process.kill()
                process.wait()
    if not talked.strip() or not heard.strip():
        raise RuntimeError(f'a discovery process failed: {talker_err[-300:]} '
                           f'{listener_err[-300:]}')
    talker_result, listener_result = json.loads(talked), json.loads(heard)

    def since(value):
        return None if value is None else value - started

    return {'talker ready': since(talker_result['ready']),
            'talker matched': since(talker_result['matched']),
            'listener matched': since(listener_result['matched']),
            'first message': since(listener_result['first']),
            'received': listener_result['received'],
            'missing after first': listener_result['missing_after_first'],
            'sent': talker_result['sent']}


def summary(label: str, stagger: float, runs: list) -> list:
    """One markdown table row for ``runs`` of one configuration."""
    def spread(key):
        values = [run[key] for run in runs if run[key] is not None]
        if not values:
            return 'never'
        never = len(runs) - len(values)
        text = f'{statistics.median(values):.2f} / {max(values):.2f}'
        return text + (f' (never in {never})' if never else '')

    slow = sum(1 for run in runs if run['first message'] is None
               or run['first message'] - run['talker ready'] > SLOW)
    missing = sum(run['missing after first'] or 0 for run in runs)
    firsts = ' '.join('-' if run['first message'] is None else f'{run["first message"]:.2f}'
                      for run in runs)
    return [label, f'{stagger:g}', spread('talker ready'), spread('talker matched'),
            spread('listener matched'), spread('first message'), f'{slow} of {len(runs)}',
            str(missing), firsts]


HEADER = ['configuration (LOCALHOST)', 'talker started after the listener', 'talker node up',
          'talker matched', 'listener matched', 'first message', f'runs > {SLOW:g} s',
          'lost after the first', 'first message, per run']


def measure(runs: int, stagger: float) -> list:
    """Rows of the table, one per configuration."""
    with tempfile.TemporaryDirectory() as scratch:
        rows = []
        for label, environment, factor in configurations(Path(scratch)):
            results = [one_run(environment, stagger * factor) for _ in range(runs)]
            rows.append(summary(label, stagger * factor, results))
            print(' | '.join(rows[-1]), flush=True)
        return rows


def main(args=None) -> int:
    """Print the table for ``--runs`` runs per configuration."""
    parser = argparse.ArgumentParser(prog='benchmarks.discovery',
                                     description=__doc__.splitlines()[1])
    parser.add_argument('--runs', type=int, default=6, help='runs per configuration')
    parser.add_argument('--stagger', type=float, default=1.0,
                        help='seconds between the listener and the talker start')
    options = parser.parse_args(args)
    if options.runs < 1:
        parser.error(f'--runs: expected at least 1, got {options.runs}')
    if options.stagger < 0:
        parser.error(f'--stagger: expected seconds >= 0, got {options.stagger:g}')
    print(f'{MESSAGES} messages at {1 / PERIOD:g} Hz; seconds after the talker process '
          'started, median / max', flush=True)
    rows = measure(options.runs, options.stagger)
    print()
    print('| ' + ' | '.join(HEADER) + ' |')
    print('|' + '---|' * len(HEADER))
    for row in rows:
        print('| ' + ' | '.join(row) + ' |')
    return 0


if __name__ == '__main__':
    sys.exit(main())
