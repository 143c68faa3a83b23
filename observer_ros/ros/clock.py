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
The node clock guarded against ``/clock`` messages that are no time.

With ``use_sim_time`` rclpy's time source turns every ``/clock`` message into a ``Time``;
:func:`guard_clock` makes a node drop (and report) the ones that would raise there.
"""

from typing import Callable

from rclpy.node import Node

from observer_ros.ros.messages import LATEST_STAMP_NS, stamp_problem, stamp_to_ns


def guard_clock(node: Node, on_invalid: Callable[[str], None]) -> None:
    """
    Make ``node`` drop ``/clock`` messages that are no time instead of dying on them.

    rclpy's time source turns every ``/clock`` into a ``Time``, which raises inside the
    subscription callback for a negative ``sec`` (and takes ``nanosec >= 1e9`` or times
    beyond what a stamp holds as they come). With ``use_sim_time`` that kills the node; the
    guard passes only valid times on and reports the others to ``on_invalid``.
    """
    source = node._time_source  # rclpy exposes no hook on the /clock callback
    original = source.clock_callback

    def checked(message) -> None:
        stamp = message.clock
        problem = stamp_problem(stamp.sec, stamp.nanosec)
        if problem is None and stamp_to_ns(stamp) > LATEST_STAMP_NS:
            problem = f'sec={stamp.sec} is beyond what a stamp holds'
        if problem:
            on_invalid(problem)
            return
        original(message)

    source.clock_callback = checked  # a /clock subscription made later binds this one
    if source._clock_sub is not None:
        source._clock_sub.callback = checked


__all__ = ['guard_clock']
