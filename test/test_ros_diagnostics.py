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
Health on ``/diagnostics`` over real DDS: a stale input, an NIS violation, the statuses.

The observer, a plant or a feeder and a listener run as rclpy nodes in the test process;
their traffic goes through DDS like that of separate processes.
"""

import math

from rclpy.node import Node

from conftest import CONFIG_DIR
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.nodes.observer import ObserverNode
from observer_ros.nodes.plant_simulator import PlantSimulatorNode
from observer_ros.nodes.state_feedback import StateFeedbackNode
from observer_ros.ros.messages import VectorCodec
from observer_ros.ros.qos import publisher_qos
from ros_support import (
    DiagnosticsListener, executor_with, overrides, ros_context, spin_until)

KALMAN = str(CONFIG_DIR / 'kalman_noisy.yaml')
PERIOD_NS = 10_000_000


class Feeder(Node):
    """Publish ``y`` and ``u`` at 100 Hz (stamps 10 ms apart); ``y`` can be paused."""

    def __init__(self, system, **kwargs) -> None:
        super().__init__('feeder', **kwargs)
        self.codecs = {topic: VectorCodec.for_topic(system, topic) for topic in ('y', 'u')}
        self.publishers_ = {topic: self.create_publisher(codec.message_class, topic,
                                                         publisher_qos())
                            for topic, codec in self.codecs.items()}
        self.start_ns = self.get_clock().now().nanoseconds
        self.index = 0
        self.publish_y = True
        self.create_timer(PERIOD_NS / 1e9, self._tick)

    def _tick(self) -> None:
        stamp = self.start_ns + self.index * PERIOD_NS
        self.index += 1
        self.publishers_['u'].publish(self.codecs['u'].encode(stamp, [0.0]))
        if self.publish_y:
            self.publishers_['y'].publish(
                self.codecs['y'].encode(stamp, [math.cos(2.0 * self.index * 0.01)]))


def test_stale_measurement_raises_the_inputs_level_and_clears_when_it_resumes():
    system = validate_parameters(load_parameter_file(KALMAN))
    with ros_context('--params-file', KALMAN) as context:
        observer = ObserverNode(context=context, parameter_overrides=overrides(
            diagnostics__period=0.1))
        listener = DiagnosticsListener(context=context)
        feeder = Feeder(system, context=context)
        name = '/observer: inputs'
        with executor_with(context, observer, listener, feeder) as executor:
            assert spin_until(executor, lambda: listener.level_is(name, 'OK'), 20.0), (
                listener.statuses.get(name))
            level, message, values = listener.latest(name)
            assert float(values['y.rate_hz']) == 100.0 and values['y.expected_rate_hz'] == '100'
            assert listener.hardware_ids[name] == '/observer'
            feeder.publish_y = False
            since = listener.count(name)
            assert spin_until(executor, lambda: listener.level_is(name, 'ERROR', since),
                              10.0), listener.statuses[name][since:]
            stale = next(r for r in listener.statuses[name][since:] if r[0] == 'ERROR')
            assert stale[1].startswith('y stale for ')
            assert stale[1].endswith(' s (expected every 0.01 s)'), stale[1]
            assert 'u stale' not in stale[1]
            assert float(stale[2]['y.age_s']) >= 0.5  # the automatic timeout: 10 periods, 0.5 s
            feeder.publish_y = True
            since = listener.count(name)
            assert spin_until(executor, lambda: listener.level_is(name, 'OK', since), 10.0), (
                listener.statuses[name][since:])


def _nis_reports(measurement_noise: float, corrected: bool = False) -> tuple:
    """
    Run a real-time plant with that measurement noise into the Kalman observer (R = 1e-4).

    Returns the estimator reports with a full NIS window and, with ``corrected``, those
    after ``observer.measurement_noise`` was set to the plant's at run time.
    """
    with ros_context('--params-file', KALMAN) as context:
        observer = ObserverNode(context=context, parameter_overrides=overrides(
            diagnostics__period=0.2, diagnostics__nis_window=50,
            diagnostics__nis_confidence=0.999))
        listener = DiagnosticsListener(context=context)
        plant = PlantSimulatorNode(context=context, parameter_overrides=overrides(
            plant__wait_for_command=False, plant__measurement_noise=[measurement_noise]))
        name = '/observer: estimator'

        def full_reports(since=0):
            return [r for r in listener.statuses.get(name, [])[since:]
                    if r[2]['nis.samples'] == '50']

        after = []
        with executor_with(context, observer, listener, plant) as executor:
            assert spin_until(executor, lambda: len(full_reports()) >= 5, 30.0), (
                listener.statuses.get(name))
            reports = full_reports()
            if corrected:
                result, = observer.set_parameters(overrides(
                    observer__measurement_noise=[measurement_noise]))
                assert result.successful, result.reason
                since = listener.count(name)
                assert spin_until(executor, lambda: len(full_reports(since)) >= 3, 30.0), (
                    listener.statuses[name][since:])
                after = full_reports(since)
        return reports, after


def test_nis_violation_with_a_too_small_measurement_noise_warns():
    # The data: 100 times the configured R = 1e-4; then R is corrected at run time.
    reports, after = _nis_reports(1e-2, corrected=True)
    assert any(level == 'WARN' for level, _, _ in reports), reports
    level, message, values = next(r for r in reports if r[0] == 'WARN')
    assert message.startswith('NIS mean ') and 'above the 99.9% bound' in message, message
    assert message.endswith('over 50 samples: R or Q too small (or a model error)')
    assert float(values['nis.mean']) > 10 * float(values['nis.bound_high'])
    # The window restarts with the new filter: no old NIS value keeps it above the bound.
    assert [level for level, _, _ in after] == ['OK'] * len(after), after


def test_nis_with_the_configured_measurement_noise_stays_ok():
    reports, _ = _nis_reports(1e-4)
    assert all(level == 'OK' for level, _, _ in reports), reports
    low, high = float(reports[0][2]['nis.bound_low']), float(reports[0][2]['nis.bound_high'])
    assert all(low <= float(values['nis.mean']) <= high for _, _, values in reports)


def test_every_node_reports_configuration_and_inputs_with_its_own_hardware_id():
    with ros_context('--params-file', KALMAN) as context:
        settings = overrides(diagnostics__period=0.1)
        nodes = [PlantSimulatorNode(context=context, parameter_overrides=settings),
                 ObserverNode(context=context, parameter_overrides=settings + overrides(
                     diagnostics__nis_confidence=0.999)),
                 StateFeedbackNode(context=context, parameter_overrides=settings + overrides(
                     diagnostics__hardware_id='robot1_controller'))]
        listener = DiagnosticsListener(context=context)
        expected = ['/plant_simulator: configuration', '/plant_simulator: inputs',
                    '/observer: configuration', '/observer: inputs', '/observer: estimator',
                    '/state_feedback: configuration', '/state_feedback: inputs']
        with executor_with(context, *nodes, listener) as executor:
            assert spin_until(executor, lambda: all(listener.count(name) for name in expected)
                              and 'covariance.trace' in listener.latest(
                                  '/observer: estimator')[2]
                              and 'measurements' in listener.latest('/observer: inputs')[2]
                              and listener.latest('/state_feedback: inputs')[0] == 'OK',
                              20.0), listener.statuses
    configuration = listener.latest('/observer: configuration')
    assert configuration[0] == 'OK'
    assert configuration[2]['observable'] == 'true'
    assert configuration[2]['observer_type'] == 'kalman'
    assert configuration[2]['observer_poles'].count('j') == 2
    assert listener.latest('/state_feedback: configuration')[2]['feedback_poles'] == '-3-2j, -3+2j'
    assert listener.hardware_ids['/state_feedback: inputs'] == 'robot1_controller'
    assert listener.hardware_ids['/plant_simulator: inputs'] == '/plant_simulator'
    inputs = listener.latest('/observer: inputs')[2]
    assert int(inputs['measurements']) > 0 and 'future_stamp' not in inputs  # non-zero only
    estimator = listener.latest('/observer: estimator')
    assert estimator[0] == 'OK', estimator
    estimator = estimator[2]
    assert float(estimator['covariance.trace']) > 0 and float(estimator['innovation.rms']) > 0
    assert listener.latest('/state_feedback: inputs')[2]['reference.age_s'] == 'never'


def test_period_zero_publishes_no_diagnostics():
    with ros_context('--params-file', KALMAN) as context:
        observer = ObserverNode(context=context, parameter_overrides=overrides(
            diagnostics__period=0.0))
        assert observer.diagnostics.timer is None
        topics = dict(observer.get_topic_names_and_types())
        publishers = observer.get_publishers_info_by_topic('/diagnostics')
        observer.destroy_node()
    assert not [info for info in publishers if info.node_name == 'observer'], topics
