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
The observer's per-message path in its own layer (issue 29): few calls, the same behaviour.

A ``y`` and a ``u`` are the node's busiest messages: their callbacks write out the steps
of decoding, running the stream and counting the health (no wrapper calls), and the
reader checks a repeated layout in place. Counted with ``sys.setprofile``, only the calls
into ``observer_ros.nodes``, ``observer_ros.ros`` and ``observer_ros.wire`` (the engine's
own calls are its business).
"""

from collections import Counter
import os
import sys

import pytest
from test_lean_path import callbacks, CONFIG, CONTROLLER, message, recorded, STEP_NS

import observer_ros
from observer_ros.nodes.observer import ObserverNode
from observer_ros.nodes.observer_controller import ObserverControllerNode
from observer_ros.wire import DecodeError
from observer_ros.wire.vectors import MessageReader
from ros_support import ros_context

#: The node's own layers, by folder.
LAYERS = tuple(os.path.join(os.path.dirname(observer_ros.__file__), folder, '')
               for folder in ('nodes', 'ros', 'wire'))

#: Calls into those layers for one steady ``y`` (estimate published) and its ``u``
#: (19 and 10 before the callbacks were written out).
# One call more each than the inline version measured (11, 5): what follows every answer
# (publish, the input wait, the health count) is one method, _answered, not three copies.
CALL_BUDGET = {'y': 12, 'u': 6}


def layer_calls(callback, raw: bytes) -> Counter:
    """Return the calls into the node's layers while ``callback(raw)`` runs, by name."""
    calls = Counter()

    def profile(frame, event, arg):
        if event == 'call' and frame.f_code.co_filename.startswith(LAYERS):
            calls[frame.f_code.co_name] += 1
    sys.setprofile(profile)
    try:
        callback(raw)
    finally:
        sys.setprofile(None)
    return calls


def test_a_steady_y_and_its_u_make_few_calls_in_the_node_s_layers():
    with ros_context('--params-file', str(CONFIG)) as context:
        node = ObserverNode(context=context)
        try:
            x_hat = []
            recorded(node.observer_part.x_hat_publisher, x_hat)
            on = callbacks(node)
            for k in range(1, 51):
                on['y'](message('y1', k * STEP_NS, 0.1))
                on['u'](message('u1', k * STEP_NS, 0.0))
            assert len(x_hat) == 50
            y_calls = layer_calls(on['y'], message('y1', 51 * STEP_NS, 0.1))
            assert len(x_hat) == 51  # the steady case: the y gave its estimate at once
            u_calls = layer_calls(on['u'], message('u1', 51 * STEP_NS, 0.0))
        finally:
            node.destroy_node()
    assert sum(y_calls.values()) <= CALL_BUDGET['y'], y_calls
    assert sum(u_calls.values()) <= CALL_BUDGET['u'], u_calls


def test_malformed_and_zero_stamped_messages_take_the_written_out_path_as_before():
    with ros_context('--params-file', str(CONFIG)) as context:
        node = ObserverNode(context=context)
        try:
            part = node.observer_part
            x_hat = []
            recorded(part.x_hat_publisher, x_hat)
            on = callbacks(node)
            on['y'](b'\x00\x01\x00\x00\x01')  # truncated
            on['u'](b'\x00\x01\x00\x00\x01')
            assert part.node_counters['malformed'] == 2 and x_hat == []
            warned = node.__dict__.get('_warned', set())
            assert {'malformed y', 'malformed u'} <= warned
            on['u'](message('u1', 0, 0.0))  # a zero stamp: stamped on arrival
            on['y'](message('y1', 0, 0.1))
            assert {'zero stamp y', 'zero stamp u'} <= warned
            assert part.health.monitors['y'].count == 1
        finally:
            node.destroy_node()


def test_the_reader_checks_a_repeated_layout_in_place_whatever_holds_the_bytes():
    reader = MessageReader('joint_state', 'position', ['y1'])
    first, second = message('y1', 7, 0.5), message('y1', 3 * STEP_NS, -2.0)
    assert reader.read_parts(first) == (0, 7, [0.5])
    for raw in (second, bytearray(second), memoryview(second)):
        assert reader.read_parts(raw) == (0, 3 * STEP_NS, [-2.0])
    other = message('y2', 5, 1.0)  # same size, another joint: not the last layout
    assert len(other) == len(first)
    with pytest.raises(DecodeError, match='y1'):
        reader.read_parts(other)
    assert reader.read_parts(second) == (0, 3 * STEP_NS, [-2.0])


def test_commands_do_not_re_arm_the_watchdog_which_waits_out_the_rest_itself():
    # Before, every command reset the watchdog timer: with the EventsExecutor that wakes its
    # timer thread once per message (7 us per round of the controller in benchmark 4).
    with ros_context('--params-file', str(CONFIG)) as context:
        node = ObserverControllerNode(context=context, parameter_overrides=CONTROLLER)
        try:
            part = node.feedback_part
            commands, resets = [], []
            recorded(part.publisher, commands)
            watchdog = part.watchdog
            reset = watchdog.reset
            watchdog.reset = lambda: resets.append(watchdog.timer_period_ns) or reset()
            on_y = callbacks(node)['y']
            for k in range(1, 41):
                on_y(message('y1', k * STEP_NS, 0.0))
            assert len(commands) >= 30
            timeout_ns = int(node.system.feedback.timeout * 1e9)
            assert resets == [timeout_ns]  # armed by the first command only
            # The timer fires while estimates keep coming: it waits the rest, no safe command.
            part.last_estimate_ns -= timeout_ns // 4
            part._on_watchdog()
            assert not part.stale and not watchdog.is_canceled()
            assert len(resets) == 2 and 0 < resets[1] <= timeout_ns - timeout_ns // 4
            # Then nothing for the whole timeout: stale, the safe command goes out.
            part.last_estimate_ns -= timeout_ns
            sent = len(commands)
            part._on_watchdog()
            assert part.stale and watchdog.is_canceled() and len(commands) == sent + 1
            # The next estimate ends the stale spell and arms the watchdog again.
            on_y(message('y1', 41 * STEP_NS, 0.0))
            assert not part.stale and resets[-1] == timeout_ns
        finally:
            node.destroy_node()
