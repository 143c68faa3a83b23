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
``play_bag``: publish a bag's topics again, with ``/clock``, to test nodes against it.

The online counterpart of ``replay``: the unchanged ``observer`` node, started with
``use_sim_time``, subscribes to what this player publishes. Messages go out as recorded (the
stored CDR bytes, in log-time order), each preceded by ``/clock`` at its log time, so nodes
that stamp on arrival see the bag's time, as the offline replay assumes.

Two pacings:

* recorded timing (``--rate R`` scales it), as ``ros2 bag play`` does;
* ``--paced-by x_hat``: as fast as the node under test keeps up. After each message on the
  trigger topic (``--trigger``, default ``/y``) the player waits for the response carrying the
  trigger's stamp (or, for a response without a header, for the next response message)
  before it publishes anything else. Nothing is lost to queues, so the node's output equals
  the offline replay's, message by message. With several trigger topics (the measurement
  sources of an observer: ``--trigger /joint_states /imu/data /mocap/pose``) each waits
  for the next response message, whatever its stamp (a late measurement's answer carries
  the newest stamp).

Remap topics with ``--ros-args -r /y:=/joint_states``. A bag that cannot be played (missing
topic, message type not installed, fewer messages than its metadata counts) stops with one
line and exit status 2.
"""

import argparse
from collections import Counter
from dataclasses import dataclass, field
import sys
import time
from typing import Optional, Sequence, Union

import rclpy
from rclpy.duration import Duration
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.serialization import deserialize_message
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args
from rosgraph_msgs.msg import Clock

from observer_ros.bags.storage import (
    absolute_topic, BagError, Playback, playback_class, playback_classes)
from observer_ros.core.units import NANOSECONDS
from observer_ros.ros.messages import stamp_to_ns
from observer_ros.ros.qos import volatile_qos
from observer_ros.signals import StopSignals


#: Seconds between discovery matching and the first message.
SETTLE = 0.2

#: Seconds the player stays after its last message at recorded timing.
LINGER = 0.5

#: Played topics: reliable, deep enough for bursts at recorded timing.
PLAYER_QOS = volatile_qos(1000, reliable=True)

#: ``/clock`` as ``ros2 bag play`` offers it (reliable writers match best-effort readers).
CLOCK_QOS = volatile_qos(1, reliable=True)

#: The response subscription: best effort matches every publisher; deep, so none is lost.
RESPONSE_QOS = volatile_qos(1000, reliable=False)


def _stamp_ns(message) -> Optional[int]:
    header = getattr(message, 'header', None)
    return None if header is None else stamp_to_ns(header.stamp)


@dataclass
class PlayResult:
    """What a play published and, when paced, how the node under test answered."""

    published: Counter = field(default_factory=Counter)
    answered: int = 0
    unanswered: int = 0
    elapsed: float = 0.0
    bag_duration: float = 0.0

    def summary(self) -> str:
        """One line for the console."""
        topics = ', '.join(f'{topic} {count}' for topic, count in sorted(self.published.items()))
        text = (f'played {sum(self.published.values())} messages ({topics}) covering '
                f'{self.bag_duration:.3f} s of bag time in {self.elapsed:.3f} s')
        if self.answered or self.unanswered:
            text += f'; {self.answered} answered, {self.unanswered} unanswered'
        return text


class BagPlayer(Node):
    """
    Publish a bag's messages, with ``/clock``, at recorded timing or paced by a response.

    Parameters
    ----------
    playback : Playback
        The opened bag and the topics to play.
    rate : float
        Recorded timing is divided by this (2.0 plays twice as fast). Ignored when paced.
    clock : bool
        Publish ``/clock`` at each message's log time before the message.
    paced_by : str, optional
        Response topic; with it, each ``trigger`` message waits for its response.
    trigger : str or sequence of str
        The played topic(s) whose messages expect a response; with several, each waits for
        the next response message.
    response_timeout : float
        Seconds to wait for a response before counting it unanswered and going on.
    wait_for : sequence of str
        Played topics that must have a matched subscriber before the first message (the
        trigger is implied when paced).

    Raises
    ------
    BagError
        A played message type is not installed, ``/clock`` is both played and published,
        or the trigger is not played.

    """

    def __init__(self, playback: Playback, rate: float = 1.0, clock: bool = True,
                 paced_by: Optional[str] = None, trigger: Union[str, Sequence[str]] = '/y',
                 response_timeout: float = 1.0, wait_for: Sequence[str] = (),
                 node_name: str = 'bag_player',
                 **kwargs) -> None:
        if not rate > 0.0:
            raise BagError(f'--rate: expected a positive factor, got {rate}')
        if not response_timeout > 0.0:
            raise BagError(f'--response-timeout: expected positive seconds, got '
                           f'{response_timeout}')
        if clock and '/clock' in playback.topics:
            raise BagError(f'{playback.path}: the bag has /clock itself; play it with '
                           f'--no-clock or leave it out with --exclude /clock')
        triggers = [trigger] if isinstance(trigger, str) else list(trigger)
        triggers = [absolute_topic(topic) for topic in triggers]
        if paced_by is not None:
            paced_by = absolute_topic(paced_by)
            for trigger in triggers:
                if trigger not in playback.topics:
                    raise BagError(f'--trigger: {trigger} is not among the played topics '
                                   f'({playback.listing()})')
            if paced_by in playback.topics:
                raise BagError(f'--paced-by: {paced_by} is also played from the bag; leave '
                               f'it out with --exclude {paced_by}')
        wait_for = [absolute_topic(topic) for topic in wait_for]
        if paced_by is not None:
            wait_for += triggers
        unknown = sorted(set(wait_for) - set(playback.topics))
        if unknown:
            raise BagError(f'--wait-for: {", ".join(unknown)} not among the played topics '
                           f'({playback.listing()})')
        classes = playback_classes(playback)
        kwargs.setdefault('start_parameter_services', False)
        super().__init__(node_name, **kwargs)
        self.playback = playback
        self.rate = rate
        self.paced_by = paced_by
        self.triggers = triggers
        self.by_count = len(triggers) > 1
        self.wait_for = wait_for
        self.response_timeout = response_timeout
        self.classes = classes
        self.publishers_by_topic = {topic: self.create_publisher(cls, topic, PLAYER_QOS)
                                    for topic, cls in classes.items()}
        self.clock_publisher = (self.create_publisher(Clock, '/clock', CLOCK_QOS)
                                if clock else None)
        self.response_subscription = None
        self._responses: set = set()
        self._response_count = 0
        self._response_stamped = False

    def _on_response(self, message) -> None:
        self._response_count += 1
        stamp = _stamp_ns(message)
        if stamp is not None:
            self._responses.add(stamp)

    def _subscribe_response(self) -> bool:
        if self.response_subscription is not None:
            return True
        resolved = self.resolve_topic_name(self.paced_by)
        for name, types in self.get_topic_names_and_types():
            if name == resolved and types:
                cls = playback_class(types[0], self.paced_by)
                self.response_subscription = self.create_subscription(
                    cls, self.paced_by, self._on_response, RESPONSE_QOS)
                self._response_stamped = hasattr(cls(), 'header')
                return True
        return False

    def ready(self) -> bool:
        """Whether the awaited subscribers (and, paced, the response) are matched."""
        for publisher in self.publishers_by_topic.values():
            if publisher.get_subscription_count() < self.count_subscribers(
                    publisher.topic_name):
                return False
        for topic in self.wait_for:
            if self.publishers_by_topic[topic].get_subscription_count() == 0:
                return False
        if self.paced_by is None:
            return True
        return (self._subscribe_response()
                and self.response_subscription.get_publisher_count() > 0)

    def wait_until_ready(self, executor, timeout: float) -> None:
        """
        Wait for discovery before the first message.

        Once matched, the player waits :data:`SETTLE` seconds more: a publisher may see its
        subscriber a moment before the subscriber accepts its data.

        Raises
        ------
        BagError
            An awaited topic has no subscriber, or (paced) nobody publishes the response,
            within ``timeout``.

        """
        deadline = time.monotonic() + timeout
        while not self.ready():
            if time.monotonic() > deadline:
                if self.wait_for:
                    missing = [self.resolve_topic_name(topic) for topic in self.wait_for
                               if not self.publishers_by_topic[topic].get_subscription_count()]
                    if self.paced_by is not None and not missing:
                        missing = [f'(no publisher of {self.resolve_topic_name(self.paced_by)})']
                    raise BagError(
                        f'within {timeout} s nobody subscribed to {", ".join(missing)}; is '
                        f'the node under test running (with matching remappings)?')
                self.get_logger().warning(
                    f'not every subscriber matched within {timeout} s; playing anyway')
                return
            executor.spin_once(timeout_sec=0.01)
        if self.wait_for:
            time.sleep(SETTLE)

    def _await_response(self, executor, stamp: Optional[int], count_before: int) -> bool:
        deadline = time.monotonic() + self.response_timeout
        while True:
            if stamp is not None and stamp in self._responses:
                self._responses = {s for s in self._responses if s > stamp}
                return True
            if stamp is None and self._response_count > count_before:
                return True
            if time.monotonic() > deadline:
                return False
            executor.spin_once(timeout_sec=0.01)

    def play(self, executor, discovery_timeout: float = 10.0) -> PlayResult:
        """
        Publish every message; return the counts.

        Raises
        ------
        BagError
            Unreadable messages, or fewer messages than the metadata counts (after
            publishing what could be read).

        """
        self.wait_until_ready(executor, discovery_timeout)
        result = PlayResult()
        published = result.published
        started = time.monotonic()
        first = last = last_clock = None
        for topic, log_time, raw in self.playback.messages():
            if first is None:
                first = log_time
            last = log_time
            if self.paced_by is None:
                remaining = started + (log_time - first) / NANOSECONDS / self.rate - (
                    time.monotonic())
                if remaining > 0.0:
                    time.sleep(remaining)
            if self.clock_publisher is not None and log_time != last_clock:
                clock = Clock()
                clock.clock.sec, clock.clock.nanosec = divmod(log_time, NANOSECONDS)
                self.clock_publisher.publish(clock)
                last_clock = log_time
            paced = self.paced_by is not None and topic in self.triggers
            if paced:
                stamp = (None if self.by_count
                         else _stamp_ns(deserialize_message(raw, self.classes[topic])))
                count_before = self._response_count
            self.publishers_by_topic[topic].publish(raw)
            published[topic] += 1
            if paced:
                # The node stamps an unstamped (or zero-stamped) message with /clock.
                expected = ((stamp or log_time) if self._response_stamped
                            and not self.by_count else None)
                if self._await_response(executor, expected, count_before):
                    result.answered += 1
                else:
                    result.unanswered += 1
                    self.get_logger().warning(
                        f'no {self.paced_by} answered the {topic} message logged at '
                        f'{log_time} ns within {self.response_timeout} s', once=True)
        for publisher in self.publishers_by_topic.values():
            publisher.wait_for_all_acked(Duration(seconds=2.0))
        if self.paced_by is None:
            # Best-effort subscribers do not acknowledge; a participant that leaves at once
            # can take its last messages with it.
            time.sleep(LINGER)
        result.elapsed = time.monotonic() - started
        result.bag_duration = 0.0 if first is None else (last - first) / NANOSECONDS
        self.playback.check_counts(published)
        return result


def main(args: Optional[Sequence[str]] = None) -> int:
    """Entry point of ``play_bag`` (also ``ros2 run observer_ros play_bag``)."""
    argv = list(sys.argv if args is None else args)
    parser = argparse.ArgumentParser(
        prog='play_bag', description='Publish a rosbag2 bag with /clock, at recorded timing '
        'or paced by the response of the node under test.')
    parser.add_argument('bag', help='rosbag2 bag directory (MCAP or sqlite3)')
    parser.add_argument('--topics', nargs='+', metavar='TOPIC',
                        help='play only these topics (default: all)')
    parser.add_argument('--exclude', nargs='+', metavar='TOPIC', default=[],
                        help='leave these topics out')
    parser.add_argument('--rate', type=float, default=1.0,
                        help='recorded timing divided by this (default 1.0)')
    parser.add_argument('--no-clock', action='store_true', help='do not publish /clock')
    parser.add_argument('--paced-by', metavar='TOPIC',
                        help='wait for the response on TOPIC (e.g. x_hat) after each trigger')
    parser.add_argument('--trigger', nargs='+', default=['/y'], metavar='TOPIC',
                        help='played topic(s) whose messages expect a response (default /y; '
                        'several: each waits for the next response)')
    parser.add_argument('--wait-for', nargs='+', default=[], metavar='TOPIC',
                        help='start once these played topics have a subscriber')
    parser.add_argument('--response-timeout', type=float, default=1.0, metavar='SECONDS')
    parser.add_argument('--wait', type=float, default=10.0, metavar='SECONDS',
                        help='wait at most this long for subscribers (default 10)')
    options = parser.parse_args(remove_ros_args(argv)[1:])
    try:
        playback = Playback(options.bag, options.topics, options.exclude)
    except BagError as e:
        print(f'play_bag: error: {e}', file=sys.stderr)
        return 2
    # The player's loop is Python code on the SingleThreadedExecutor: the first SIGINT or
    # SIGTERM may raise KeyboardInterrupt there; any later one is ignored (observer_ros.signals).
    with StopSignals(interrupt=True):
        node = None
        try:
            rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
            node = BagPlayer(playback, options.rate, not options.no_clock, options.paced_by,
                             options.trigger, options.response_timeout, options.wait_for)
            executor = SingleThreadedExecutor()
            executor.add_node(node)
            print(node.play(executor, options.wait).summary(), flush=True)
        except BagError as e:
            print(f'play_bag: error: {e}', file=sys.stderr)
            return 2
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        finally:
            playback.close()
            if node is not None:
                node.destroy_node()
            rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    sys.exit(main())
