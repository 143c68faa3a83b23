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
Health on ``/diagnostics`` (``diagnostic_msgs/DiagnosticArray``).

Each node publishes, every ``diagnostics.period`` seconds of the steady clock (so a stopped
``/clock`` does not silence it), several ``DiagnosticStatus`` entries named
``'<fully qualified node name>: <section>'`` (``/robot1/observer: inputs``) with
``hardware_id`` = ``diagnostics.hardware_id`` or, when empty, the fully qualified name, the
way ``diagnostic_aggregator`` groups them:

- ``configuration``: the model, observability, observer type and poles, feedback and
  closed-loop poles;
- ``inputs``: each input's rate (from its stamps) against the expected one, its age (stale
  inputs), and the node's counters with the dropped or repaired data since the last report;
- ``estimator`` (observer only): the innovation magnitude, estimator restarts and, with a
  Kalman filter, the windowed NIS against its chi-square bounds and the trace of ``P``.

The checks are computed by :mod:`observer_ros.app.health`; this module only fills the
messages. ``/diagnostics`` is an absolute name: it stays global in a namespace.
"""

from collections import deque
import time
from typing import Callable, Optional, Sequence

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from rclpy.clock import Clock, ClockType
from rclpy.node import Node

from observer_ros.app.design_check import configuration_check
from observer_ros.app.health import (
    Check, combine, CounterWatch, covariance_values, ESTIMATOR_WARNING_COUNTERS,
    innovation_values, INPUT_WARNING_COUNTERS, InputMonitor, nis_findings, stale_timeout,
    WARNING_COUNTERS)
from observer_ros.core.consistency import NisWindow

#: The topic every node reports on (absolute: not namespaced, as ROS expects).
DIAGNOSTICS_TOPIC = '/diagnostics'

__all__ = ['DIAGNOSTICS_TOPIC', 'DiagnosticsPublisher', 'NodeHealth', 'WARNING_COUNTERS',
           'expected_rate', 'input_check', 'monitor', 'status_message']


def expected_rate(system) -> float:
    """``diagnostics.expected_rate``, or the plant rate when it is 0 (the sample rate)."""
    return system.sample_rate_hz


def status_message(check: Check, name: str, hardware_id: str) -> DiagnosticStatus:
    """Return the ``DiagnosticStatus`` of one check of the node called ``name``."""
    return DiagnosticStatus(
        level=bytes([check.level]), name=f'{name}: {check.section}', message=check.message,
        hardware_id=hardware_id,
        values=[KeyValue(key=key, value=value) for key, value in check.values])


def input_check(monitors: Sequence[InputMonitor], watch: CounterWatch, counters: dict,
                now_ns: int) -> Check:
    """Return the ``inputs`` check: every monitor, the grown counters, all counters."""
    findings, values = [], []
    for monitor in monitors:
        found, shown = monitor.findings(now_ns)
        findings += found
        values += shown
    findings += watch.findings(counters)
    values += sorted(counters.items())
    return combine('inputs', findings, values)


class DiagnosticsPublisher:
    """
    Publish a node's checks on ``/diagnostics`` every ``diagnostics.period`` seconds.

    Parameters
    ----------
    node : ConfiguredNode
        Its ``system.diagnostics`` give the period and the hardware id.
    checks : callable
        ``checks(now_ns)`` returns the :class:`~observer_ros.app.health.Check` list at
        ``now_ns`` (``time.monotonic_ns()``).

    Notes
    -----
    With ``diagnostics.period`` 0 nothing is published (:attr:`timer` is None).

    """

    def __init__(self, node: Node, checks: Callable[[int], Sequence[Check]]) -> None:
        self.node = node
        self.checks = checks
        settings = node.system.diagnostics
        self.period = settings.period
        self.hardware_id = settings.hardware_id or node.get_fully_qualified_name()
        self.publisher = self.timer = None
        if self.period > 0:
            self.publisher = node.create_publisher(DiagnosticArray, DIAGNOSTICS_TOPIC, 10)
            self.timer = node.create_timer(self.period, self.publish,
                                           clock=Clock(clock_type=ClockType.STEADY_TIME))

    def message(self, now_ns: Optional[int] = None) -> DiagnosticArray:
        """Return the current ``DiagnosticArray`` (the checks move on to a new report)."""
        now_ns = time.monotonic_ns() if now_ns is None else now_ns
        name = self.node.get_fully_qualified_name()
        message = DiagnosticArray(status=[status_message(check, name, self.hardware_id)
                                          for check in self.checks(now_ns)])
        message.header.stamp = self.node.get_clock().now().to_msg()
        return message

    def publish(self) -> None:
        """Publish the current checks."""
        self.publisher.publish(self.message())


class NodeHealth:
    """
    The health state of a node: its input monitors, counter watches and (observer) estimator.

    Parameters
    ----------
    node : ConfiguredNode
        Gives :attr:`system` (re-read at every report) and the counters.
    monitors : dict
        ``{topic: InputMonitor}`` of the node's inputs.
    counters : callable
        Returns the node's counters (a mapping).
    estimator : bool
        Also report the ``estimator`` section (the observer).
    extra : callable, optional
        ``extra(now_ns)`` returns more checks (the observer's ``sources``).

    """

    def __init__(self, node, monitors: dict, counters: Callable[[], dict],
                 estimator: bool = False,
                 extra: Optional[Callable[[int], list]] = None) -> None:
        self.extra = extra
        self.node = node
        self.monitors = monitors
        self.counters = counters
        self.input_watch = CounterWatch(INPUT_WARNING_COUNTERS,
                                        'data dropped or repaired')
        self.estimator_watch = CounterWatch(ESTIMATOR_WARNING_COUNTERS,
                                            'estimator restarted or failed')
        now = time.monotonic_ns()
        for monitor in monitors.values():
            monitor.start(now)
        self._configuration = (None, None)
        self.estimator = estimator
        system = node.system
        settings = system.diagnostics
        self.innovations = deque(maxlen=settings.nis_window)
        covariance = (estimator and system.observer is not None
                      and system.observer.kind.capabilities.covariance)
        self.nis = (NisWindow(settings.nis_window, system.model.n_outputs,
                              settings.nis_confidence) if covariance else None)
        self.covariance = None
        self.publisher = DiagnosticsPublisher(node, self.checks)

    def restart_nis(self) -> None:
        """Forget the NIS window (the filter changed: its old values test another one)."""
        if self.nis is not None:
            self.nis.clear()

    def watch(self, topic: str, monitor: InputMonitor) -> None:
        """Check ``topic`` from now on (an input subscribed after the start)."""
        monitor.start(time.monotonic_ns())
        self.monitors[topic] = monitor

    def tick(self, topic: str, stamp_ns: Optional[int]) -> None:
        """Count a decoded message on ``topic`` (unstamped: stamped with its arrival)."""
        arrival = time.monotonic_ns()
        self.monitors[topic].tick(arrival if stamp_ns is None else stamp_ns, arrival)

    def sample(self, innovation, nis: Optional[float], covariance) -> None:
        """Take one published estimate's innovation, NIS and covariance."""
        self.innovations.append(sum([value * value for value in innovation]))
        if nis is not None and self.nis is not None:
            self.nis.add(nis)
        if covariance is not None:
            self.covariance = covariance

    def configuration(self) -> Check:
        """Return the configuration check of the current system (cached per system)."""
        system = self.node.system
        cached, check = self._configuration
        if cached is system:
            return check
        observer, feedback, plant = system.observer, system.feedback, system.plant
        extra = [('expected_rate_hz', f'{expected_rate(system):.4g}')]
        if plant is not None:
            extra += [('plant_rate_hz', f'{plant.rate_hz:.4g}'),
                      ('lockstep', str(plant.lockstep).lower())]
        check = configuration_check(
            system.model, None if observer is None else observer.kind.name,
            None if observer is None else observer.design.achieved_poles,
            None if feedback is None else feedback.design.achieved_poles,
            system.loop.closed_loop_poles, system.loop.notes, extra,
            detectable=observer is not None and not observer.kind.capabilities.needs_observable)
        self._configuration = (system, check)
        return check

    def estimator_check(self) -> Check:
        """Return the estimator check: innovation, restarts, NIS window, covariance trace."""
        counters = self.counters()
        findings, values = innovation_values(list(self.innovations))
        if self.nis is not None:
            found, shown = nis_findings(self.nis)
            findings += found
            values += shown
        trace = None
        if self.covariance is not None:
            trace = float(sum(self.covariance[i][i] for i in range(len(self.covariance))))
        found, shown = covariance_values(trace)
        findings += found + self.estimator_watch.findings(counters)
        values += shown
        values += [(key, counters.get(key, 0)) for key in
                   ('estimates',) + ESTIMATOR_WARNING_COUNTERS + ('resets',)]
        return combine('estimator', findings, values)

    def checks(self, now_ns: int) -> list:
        """Return every check of the node at ``now_ns``."""
        counters = dict(self.counters())
        invalid_clock = getattr(self.node, 'invalid_clock', 0)
        if invalid_clock:
            counters['invalid_clock'] = invalid_clock
        checks = [self.configuration(),
                  input_check(list(self.monitors.values()), self.input_watch, counters,
                              now_ns)]
        if self.estimator:
            checks.append(self.estimator_check())
        if self.extra is not None:
            checks += self.extra(now_ns)
        return checks


def monitor(system, topic: str, stale_default: float, required: bool = True,
            rated: bool = True, minimum_only: bool = False) -> InputMonitor:
    """
    Return the :class:`InputMonitor` of one of a node's inputs from its parameters.

    ``stale_default`` is the node's own timeout for this input (0: automatic, see
    :func:`observer_ros.app.health.stale_timeout`), used when ``diagnostics.stale_timeout``
    is 0.
    """
    settings = system.diagnostics
    rate = expected_rate(system) if rated else None
    configured = settings.stale_timeout or stale_default
    return InputMonitor(topic, rate, stale_timeout(configured, rate),
                        settings.rate_tolerance, required, minimum_only)
