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
The ``main`` of every node: spin one node the Jazzy way and return the exit status.

:func:`run_node` reads ``--executor``, builds the node, spins it until done or stopped
(SIGINT and SIGTERM through :class:`observer_ros.signals.StopSignals`) and shuts down
cleanly; a bad configuration is one line on stderr and exit status 2, and so is a params
file the ROS loader would refuse (missing, not YAML, a list mixing ``0`` and ``1.0``): it is
read first, as ``design_observer`` reads it, rather than left to rcl's traceback.
"""

import re
import sys
from typing import Callable, Optional

import rclpy
from rclpy.executors import ExternalShutdownException
from rclpy.node import Node
from rclpy.signals import SignalHandlerOptions
from rclpy.utilities import remove_ros_args

from observer_ros.config.loader import read_parameter_document
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.ros.executors import executor_option, make_executor, spin_until
from observer_ros.signals import StopSignals


def run_node(factory: Callable[[], Node], program: str, args=None,
             done: Optional[Callable[[Node], Callable[[], bool]]] = None) -> int:
    """
    Spin one node the Jazzy way and return the exit status.

    ``--executor`` (before ``--ros-args``) picks the executor. ``done(node)`` may return a
    predicate that ends the spin. A bad configuration prints one line,
    ``<program>: error: <parameter>: <reason>``, on stderr and returns 2. SIGINT and SIGTERM
    stop the spin and return 0 after a clean shutdown; a second one is ignored
    (:class:`observer_ros.signals.StopSignals`).
    """
    argv = sys.argv if args is None else list(args)
    problem = ros_arguments_problem(argv)
    if problem:
        print(f'{program}: error: {problem}', file=sys.stderr)
        return 2
    executor_name = executor_option(program, argv)
    with StopSignals() as stop:
        # rclpy's own handlers would raise KeyboardInterrupt inside callbacks and shut the
        # context down from another thread: StopSignals replaces them.
        rclpy.init(args=argv, signal_handler_options=SignalHandlerOptions.NO)
        try:
            node = factory()
        except (ConfigError, DesignError) as e:
            print(f'{program}: error: {e}', file=sys.stderr)
            rclpy.try_shutdown()
            return 2
        executor = make_executor(executor_name)
        try:
            executor.add_node(node)
            spin_until(executor, done(node) if done else None, stop=lambda: stop.requested)
        except (KeyboardInterrupt, ExternalShutdownException):
            pass
        finally:
            executor.remove_node(node)
            node.destroy_node()
            executor.shutdown()
            rclpy.try_shutdown()
    return 0


def ros_arguments_problem(argv) -> Optional[str]:
    """
    Return why the ROS arguments of ``argv`` cannot start a node (one line), or None.

    Each ``--params-file`` is read as ``design_observer`` reads it (missing, not YAML, a list
    mixing ``0`` and ``1.0``: the parameter named); then rcl parses the rest.
    """
    try:
        for path in params_files(argv):
            read_parameter_document(path)
        remove_ros_args(list(argv))
    except ConfigError as e:
        return str(e)
    except RuntimeError as e:  # rcl's RCLInvalidROSArgsError: arguments it cannot parse
        return ros_arguments_error(e)
    return None


def params_files(argv) -> list:
    """Return the paths given to ``--params-file`` in the ``--ros-args`` parts of ``argv``."""
    paths, ros_args = [], False
    for position, argument in enumerate(argv):
        if argument == '--ros-args':
            ros_args = True
        elif argument == '--':
            ros_args = False
        elif ros_args and argument == '--params-file' and position + 1 < len(argv):
            paths.append(argv[position + 1])
    return paths


def ros_arguments_error(error: Exception) -> str:
    """Return rcl's refusal of the ROS arguments on one line, without its source locations."""
    text = ' '.join(str(error).split())
    return re.sub(r',? at [^,]*\.c:\d+', '', text).rstrip(', ')


__all__ = ['params_files', 'ros_arguments_error', 'ros_arguments_problem', 'run_node']
