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
``closed_loop``: plant simulator, observer and state feedback in one process.

The three nodes share one executor and the same parameters (``--ros-args --params-file``).
With ``plant.lockstep`` the observer and the feedback run on the plant's ``/clock``.
``--controller`` runs the plant and one ``observer_controller`` instead of the observer and
the feedback (the same commands, bit for bit, with ``controller.input: u``).
``--report DIR`` also records ``x_true`` and ``x_hat`` and, when ``plant.samples`` are done,
prints the per-state error table and writes ``DIR/closed_loop.png``.
"""

import argparse
import os
import sys
from typing import Callable, Optional

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.parameter import Parameter
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args

from observer_ros.app.plots import write_run_report
from observer_ros.bags.storage import BagError, STORAGES
from observer_ros.bags.writing import TopicToWrite, write_bag
from observer_ros.config import Configuration, validate_parameters
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.nodes.observer import ObserverNode
from observer_ros.nodes.observer_controller import ObserverControllerNode
from observer_ros.nodes.plant_simulator import plant_done, PlantSimulatorNode
from observer_ros.nodes.state_feedback import StateFeedbackNode
from observer_ros.ros.executors import add_executor_argument, make_executor, spin_until
from observer_ros.ros.recorder import TopicRecorder
from observer_ros.ros.run import ros_arguments_problem
from observer_ros.signals import StopSignals


#: Topics recorded by ``--report`` (and by tests).
RECORDED_TOPICS = ('y', 'u', 'u_cmd', 'x_true', 'x_hat')

#: Seconds the recorder may wait, once the plant is done, for the estimate of its last
#: sample: a controller publishes the last command (which ends the run) before it.
LAST_ESTIMATE_WAIT = 5.0


class ClosedLoop:
    """
    The three nodes (and an optional recorder) on one executor.

    ``controller``: the plant and one observer-controller instead (then :attr:`observer`
    and :attr:`feedback` are that node).
    """

    def __init__(self, record: bool = False, executor=None, context=None,
                 overrides=(), controller: bool = False) -> None:
        self.nodes = []
        try:
            self.plant = PlantSimulatorNode(context=context, parameter_overrides=list(overrides))
            self.nodes.append(self.plant)
            sim_time = [Parameter('use_sim_time', value=True)] if self.plant.lockstep else []
            settings = list(overrides) + sim_time
            if controller:
                self.observer = self.feedback = ObserverControllerNode(
                    context=context, parameter_overrides=settings)
                self.nodes.append(self.observer)
            else:
                self.observer = ObserverNode(context=context, parameter_overrides=settings)
                self.nodes.append(self.observer)
                self.feedback = StateFeedbackNode(context=context,
                                                  parameter_overrides=settings)
                self.nodes.append(self.feedback)
            self.recorder = None
            if record:
                self.recorder = TopicRecorder(self.system, RECORDED_TOPICS,
                                              context=context)
                self.nodes.append(self.recorder)
        except Exception:
            for node in self.nodes:
                node.destroy_node()
            raise
        self.context = context
        self.executor = executor or SingleThreadedExecutor(context=context)
        for node in self.nodes:
            self.executor.add_node(node)

    @property
    def system(self) -> Configuration:
        """Return the whole loop's configuration: the three nodes' parameters together."""
        merged = {}
        for node in (self.plant, self.observer, self.feedback):
            merged.update(node.current_parameters())
        return validate_parameters(merged)

    def spin(self, timeout_sec: Optional[float] = None,
             stop: Optional[Callable[[], bool]] = None) -> bool:
        """
        Spin until ``plant.samples`` are done (or forever, or ``stop()``); True when done.

        With a recorder, then until it has the estimate of the last sample (at most
        :data:`LAST_ESTIMATE_WAIT` seconds): an ``observer_controller`` publishes the last
        command, which ends the run, before that estimate.
        """
        done = spin_until(self.executor, plant_done(self.plant), timeout_sec, self.context,
                          stop)
        if done and self.recorder is not None:
            last = self.plant.stamp_ns

            def estimated() -> bool:
                stamps = self.recorder.stamps['x_hat']
                return bool(stamps) and stamps[-1] >= last

            spin_until(self.executor, estimated, LAST_ESTIMATE_WAIT, self.context, stop)
        return done

    def destroy(self) -> None:
        """Destroy every node and the executor."""
        for node in self.nodes:
            self.executor.remove_node(node)
            node.destroy_node()
        self.executor.shutdown()

    def report(self, directory: str) -> str:
        """Error table of ``x_hat`` against ``x_true``; writes the PNG plot into ``directory``."""
        system = self.system
        return write_run_report(directory, 'closed_loop', system,
                                *self.recorder.arrays('x_true'), *self.recorder.arrays('x_hat'),
                                title=f'{system.observer.design.kind} observer in closed loop')

    def record(self, path: str, storage: str = 'mcap') -> str:
        """Write the recorded topics to a new rosbag2 bag; return its path."""
        topics = []
        for topic in RECORDED_TOPICS:
            codec = self.recorder.codecs[topic]
            stamps, values = self.recorder.arrays(topic)
            topics.append(TopicToWrite(self.recorder.resolve_topic_name(topic), codec.kind,
                                       codec.field, codec.names, stamps,
                                       self.recorder.receive_times(topic), values))
        return str(write_bag(path, topics, storage))


def main(args=None) -> int:
    """Entry point of ``ros2 run observer_ros closed_loop``."""
    argv = sys.argv if args is None else args
    parser = argparse.ArgumentParser(
        prog='closed_loop', description='Plant, observer and state feedback in one process.')
    parser.add_argument('--report', metavar='DIR',
                        help='print the error table and write DIR/closed_loop.png at the end')
    parser.add_argument('--record', metavar='BAG',
                        help='write y, u, u_cmd, x_true and x_hat to a new rosbag2 bag at the end')
    parser.add_argument('--storage', choices=STORAGES, default='mcap',
                        help='bag storage for --record (default: mcap)')
    parser.add_argument('--controller', action='store_true',
                        help='one observer_controller node instead of observer and '
                             'state_feedback')
    add_executor_argument(parser)
    problem = ros_arguments_problem(argv)
    if problem:
        print(f'closed_loop: error: {problem}', file=sys.stderr)
        return 2
    options = parser.parse_args(remove_ros_args(argv)[1:])
    if options.record and os.path.exists(options.record):
        parser.error(f'--record: {options.record} exists already')
    with StopSignals() as stop:
        # SIGINT and SIGTERM end the spin through ``stop`` (see observer_ros.signals).
        rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
        try:
            loop = ClosedLoop(record=options.report is not None or options.record is not None,
                              executor=make_executor(options.executor),
                              controller=options.controller)
        except (ConfigError, DesignError) as e:
            print(f'closed_loop: error: {e}', file=sys.stderr)
            rclpy.try_shutdown()
            return 2
        try:
            done = loop.spin(stop=lambda: stop.requested)
            if done and options.report:
                print(loop.report(options.report))
            if done and options.record:
                print(f'bag: {loop.record(options.record, options.storage)}')
        except BagError as e:
            print(f'closed_loop: error: {e}', file=sys.stderr)
            return 2
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        finally:
            loop.destroy()
            rclpy.try_shutdown()
    return 0
