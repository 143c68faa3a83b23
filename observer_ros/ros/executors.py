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
The executors a node spins on, the bounded spin loop and the ``--executor`` option.

:func:`make_executor` builds one of :data:`EXECUTORS` by name, :func:`spin_until` spins it
until a condition, a timeout, a stop request or the ROS shutdown, and
:func:`add_executor_argument` / :func:`executor_option` read the command-line choice.
"""

import argparse
import time
from typing import Callable, Optional

import rclpy
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.utilities import remove_ros_args

#: Executors a node can spin on (``--executor``); the first is the default, the fastest in
#: BENCHMARKS.md (latency and closed-loop rate). The MultiThreadedExecutor is not offered:
#: each node's callbacks share one mutually exclusive group, so it adds only thread
#: hand-offs, and a message arriving while a callback runs waits for the next wake-up
#: (tens of milliseconds p50 for the observer in the latency benchmark).
EXECUTORS = ('events', 'single')


#: Seconds between two looks at the stop request while spinning.
STOP_POLL = 0.1


def make_executor(name: str, context=None) -> Executor:
    """
    Return the executor called ``name``.

    ``'events'`` is rclpy's ``rclpy.experimental.EventsExecutor``, ``'single'`` the
    ``SingleThreadedExecutor``.
    """
    if name == 'events':
        from rclpy.experimental import EventsExecutor
        return EventsExecutor(context=context)
    if name == 'single':
        return SingleThreadedExecutor(context=context)
    raise ValueError(f'executor: expected one of {", ".join(EXECUTORS)}, got {name!r}')


def spin_until(executor: Executor, done: Optional[Callable[[], bool]] = None,
               timeout_sec: Optional[float] = None, context=None,
               stop: Optional[Callable[[], bool]] = None) -> bool:
    """
    Spin ``executor`` until ``done()`` is true, the timeout passes or ROS shuts down.

    Always ``spin_once`` in a loop: in the rclpy 7.1 wheels ``EventsExecutor.spin()``
    delivers no message from another process, while ``spin_once`` delivers them. ``stop()``
    (for example :attr:`observer_ros.signals.StopSignals.requested`) ends the spin early;
    it is polled at least every :data:`STOP_POLL` seconds. Returns whether ``done()``
    became true.
    """
    deadline = None if timeout_sec is None else time.monotonic() + timeout_sec
    while rclpy.ok(context=context) and not (stop is not None and stop()):
        if done is not None and done():
            return True
        if deadline is not None and time.monotonic() >= deadline:
            break
        executor.spin_once(timeout_sec=STOP_POLL if deadline is None else
                           min(STOP_POLL, max(0.0, deadline - time.monotonic())))
    return done is not None and done()


def add_executor_argument(parser: argparse.ArgumentParser) -> None:
    """Add the ``--executor`` option (one of :data:`EXECUTORS`, the first by default)."""
    parser.add_argument('--executor', choices=EXECUTORS, default=EXECUTORS[0],
                        help="rclpy executor: 'events' (rclpy.experimental.EventsExecutor, the "
                        "fastest, default) or 'single' (SingleThreadedExecutor)")


def executor_option(program: str, argv) -> str:
    """Parse ``--executor`` from the non-ROS arguments (anything else is an error)."""
    parser = argparse.ArgumentParser(
        prog=program, description=f'ros2 run observer_ros {program} [--executor NAME] '
        '--ros-args ...')
    add_executor_argument(parser)
    return parser.parse_args(remove_ros_args(argv)[1:]).executor


__all__ = ['EXECUTORS', 'STOP_POLL', 'add_executor_argument', 'executor_option',
           'make_executor', 'spin_until']
