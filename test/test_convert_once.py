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
Each parameter converted once, at the edge, into its final type and unit.

One seconds-to-nanoseconds rule (:mod:`observer_ros.core.units`), checked on its edge
values and used everywhere in the package; ``observer.poles`` converted once into the
complex array the design takes; the observer part one configuration object; the stream
built once; the latency-within-history rule checked in one place.
"""

import re

import numpy as np
import pytest

from conftest import CONFIG_DIR, REPOSITORY
from observer_ros.bags.replay import load_system
from observer_ros.config import load_parameter_file, ObserverSetup, validate_parameters
import observer_ros.config.feedback as config_feedback
import observer_ros.config.observer as config_observer
import observer_ros.config.sources as config_sources
from observer_ros.core import poles
from observer_ros.core.errors import ConfigError
import observer_ros.core.observers.full_order as full_order
from observer_ros.core.sources import check_sources, MeasurementSource
from observer_ros.core.units import NANOSECONDS, rate_to_period_ns, seconds_to_ns

PACKAGE = REPOSITORY / 'observer_ros'

#: A seconds-to-nanoseconds conversion written in place: a product with ``1e9`` or
#: ``10**9``, a rounding or truncation of a product with (or a quotient of) NANOSECONDS.
INLINE_CONVERSION = re.compile(
    r'\*\s*1e9\b|\b1e9\s*\*|\*\s*10\s*\*\*\s*9\b|\b10\s*\*\*\s*9\s*\*|1_000_000_000'
    r'|\b(?:round|int)\([^()]*\*\s*NANOSECONDS\b|\b(?:round|int)\(\s*NANOSECONDS\s*/')

#: The stamp codec's integer ``sec``/``nanosec`` arithmetic: the wire package imports nothing
#: of the package (test_core_layering), so it writes its one constant; everything else asks
#: core.units.
WIRE_CODEC = ('wire/',)


@pytest.mark.parametrize('seconds, expected', [
    (0, 0), (0.0, 0), (-0.0, 0), (2, 2 * NANOSECONDS),
    (1e-9, 1), (-1e-9, -1), (0.999999999, 999_999_999), (1.000000001, 1_000_000_001),
    (0.4e-9, 0), (0.6e-9, 1), (0.5e-9, 0), (1.5e-9, 2), (2.5e-9, 2), (-0.5e-9, 0),
    (-1.5e-9, -2), (7e-9, 7), (0.3, 300_000_000), (0.01, 10_000_000),
    (3600.001, 3_600_001_000_000), (1e12, 10 ** 21), (-1e12, -10 ** 21),
])
def test_seconds_become_the_nearest_nanosecond_ties_to_even(seconds, expected):
    converted = seconds_to_ns(seconds)
    assert converted == expected and type(converted) is int


@pytest.mark.parametrize('seconds', [float('inf'), float('-inf'), float('nan'), 1e300])
def test_seconds_that_are_not_finite_in_nanoseconds_are_refused_by_name(seconds):
    with pytest.raises(ConfigError, match=r'^observer.max_gap: expected a finite number of '
                       r'seconds, got'):
        seconds_to_ns(seconds, 'observer.max_gap')


@pytest.mark.parametrize('rate, expected', [
    (100.0, 10_000_000), (3.0, 333_333_333), (30.0, 33_333_333), (1e9, 1), (3e9, 0),
    (0.01, 100 * NANOSECONDS)])
def test_a_rate_becomes_its_period_in_nanoseconds(rate, expected):
    assert rate_to_period_ns(rate) == expected


@pytest.mark.parametrize('rate', [0.0, -1.0, float('inf'), float('nan')])
def test_a_rate_that_has_no_period_is_refused_by_name(rate):
    with pytest.raises(ConfigError, match=r'^plant.rate_hz: expected a finite rate above 0'):
        rate_to_period_ns(rate, 'plant.rate_hz')


def test_the_package_converts_seconds_to_nanoseconds_with_the_one_rule_only():
    found = []
    for path in sorted(PACKAGE.rglob('*.py')):
        relative = path.relative_to(PACKAGE).as_posix()
        if relative == 'core/units.py' or relative.startswith(WIRE_CODEC):
            continue
        for number, line in enumerate(path.read_text(encoding='utf-8').splitlines(), 1):
            if INLINE_CONVERSION.search(line.split('#')[0]):
                found.append(f'{relative}:{number}: {line.strip()}')
    assert not found, 'convert with core.units.seconds_to_ns / rate_to_period_ns:\n' + (
        '\n'.join(found))


#: A motor with one measured output (doc/configuration.md's example).
MOTOR = {'model.A': [0.0, 1.0, 0.0, -2.0], 'model.B': [0.0, 4.0], 'model.C': [1.0, 0.0],
         'model.state_names': ['q', 'q_dot'], 'model.input_names': ['effort'],
         'model.output_names': ['q'], 'observer.poles': ['-8', '-9']}

#: The motor's one output from one source, a std_msgs/Float64 ``data`` that comes late.
LATE_SOURCE = {**MOTOR, 'observer.sources': ['encoder'], 'sources.encoder.type': 'float64',
               'sources.encoder.fields': ['data'], 'sources.encoder.outputs': ['q'],
               'sources.encoder.latency': 0.02}


def test_the_poles_reach_the_design_as_the_one_complex_array_made_from_the_numbers_given(
        monkeypatch):
    received, parsed = [], []
    design = full_order.design_full_order
    parse_pole = poles.parse_pole

    def receiving_design(model, requested, gain, method):
        received.append(requested)
        return design(model, requested, gain, method)

    def recording_parse(text, parameter='poles'):
        parsed.append(text)
        return parse_pole(text, parameter)

    monkeypatch.setattr(full_order, 'design_full_order', receiving_design)
    monkeypatch.setattr(poles, 'parse_pole', recording_parse)
    setup = validate_parameters({**MOTOR, 'observer.poles': [-8.0, -9]},
                                node='observer').observer
    converted = setup.arguments['poles']
    assert converted.dtype == complex and converted.tolist() == [-8, -9]
    assert len(received) == 1 and received[0] is converted  # handed on, not copied
    assert parsed == [-8.0, -9]  # each number parsed once, as a number: never a text
    assert sorted(setup.design.requested_poles.real) == [-9.0, -8.0]
    assert setup.make_estimator().design.poles is setup.design.requested_poles  # FullOrderStep


def test_the_observer_part_is_one_configuration_object_with_its_times_in_nanoseconds():
    setup = validate_parameters({**MOTOR, 'observer.max_gap': 0.3,
                                 'observer.input_wait': 1.5e-9}, node='observer').observer
    assert isinstance(setup, ObserverSetup)
    assert not hasattr(config_observer, 'DesignedObserver')  # no second object to copy from
    assert (setup.max_gap_ns, setup.input_wait_ns) == (300_000_000, 2)


def test_the_stream_validation_builds_is_the_one_the_node_takes(monkeypatch):
    built = []
    stream_class = config_observer.EventStream

    def counting_stream(*args, **kwargs):
        built.append(stream_class(*args, **kwargs))
        return built[-1]

    monkeypatch.setattr(config_observer, 'EventStream', counting_stream)
    system = validate_parameters(load_parameter_file(str(CONFIG_DIR / 'wheeled_base_sources'
                                                         '.yaml')), node='observer')
    assert len(built) == 1  # the sources and each one's updates checked once, at start-up
    assert system.observer.take_stream() is built[0]  # what the observer node runs
    assert len(built) == 1
    assert system.observer.take_stream() is not built[0] and len(built) == 2  # a fresh one


def test_the_latency_within_the_history_rule_is_the_cores_for_one_source_too():
    with pytest.raises(ConfigError, match=r"^observer.history: source 'encoder' has a latency "
                       r'of 0.02 s, longer than the history \(0 s\)'):
        validate_parameters(LATE_SOURCE, node='observer')
    setup = validate_parameters({**LATE_SOURCE, 'observer.history': 0.02},
                                node='observer').observer
    assert setup.sources.sources[0].latency_ns == 20_000_000
    assert setup.take_stream().engine.history_ns == 20_000_000


def test_the_history_within_the_gap_rule_is_the_cores_alone():
    with pytest.raises(ConfigError, match=r'^observer.history: expected 0 \.\.\. 1 s \(the gap '
                       r'limit, beyond which the estimate starts again\), got 1.5 s$'):
        validate_parameters({**MOTOR, 'observer.history': 1.5, 'observer.max_gap': 1.0},
                            node='observer')
    assert not hasattr(config_sources, 'check_history')


#: The motor with a state feedback and no observer (the feedback node's configuration).
SERVO = {key: value for key, value in MOTOR.items() if key != 'observer.poles'}


def _recording(monkeypatch, module, name, received):
    """Record the poles each call of ``module.name`` receives (its second argument)."""
    original = getattr(module, name)

    def receiving(model, *args, **kwargs):
        received.append(args)
        return original(model, *args, **kwargs)

    monkeypatch.setattr(module, name, receiving)


def _recording_parse(monkeypatch, parsed):
    parse_pole = poles.parse_pole

    def recording_parse(text, parameter='poles'):
        parsed.append(text)
        return parse_pole(text, parameter)

    monkeypatch.setattr(poles, 'parse_pole', recording_parse)


def test_the_feedback_poles_reach_the_design_as_the_one_complex_array_made_from_the_numbers(
        monkeypatch):
    received, parsed = [], []
    _recording(monkeypatch, config_feedback, 'design_feedback', received)
    _recording_parse(monkeypatch, parsed)
    system = validate_parameters({**SERVO, 'feedback.poles': [-4.0, -5]},
                                 node='state_feedback')
    converted = system.sections.feedback.poles
    assert isinstance(converted, np.ndarray) and converted.dtype == complex
    assert converted.tolist() == [-4, -5]
    assert len(received) == 1 and received[0][0] is converted  # handed on, not copied
    assert parsed == [-4.0, -5]  # each number parsed once, as a number: never a text
    assert system.sections.parameters['feedback.poles'] == ['-4.0', '-5']  # a file's form
    assert sorted(system.feedback.design.achieved_poles.real) == pytest.approx([-5.0, -4.0])


def test_the_integral_poles_are_converted_once_from_the_numbers_given_too(monkeypatch):
    received, parsed = [], []
    _recording(monkeypatch, config_feedback, 'design_integral', received)
    _recording_parse(monkeypatch, parsed)
    system = validate_parameters({**SERVO, 'feedback.poles': ['-4', -5.0],
                                  'feedback.integral_poles': [-6.0]}, node='state_feedback')
    section = system.sections.feedback
    assert section.integral.poles.dtype == complex and section.integral.poles.tolist() == [-6]
    assert parsed == ['-4', -5.0, -6.0]  # texts parsed, numbers taken as numbers, once each
    (_, all_poles, _, _, _), = received
    assert all_poles.tolist() == [-4, -5, -6]
    assert sorted(system.feedback.integral.achieved_poles.real) == pytest.approx([-6, -5, -4])


@pytest.mark.parametrize('change, message', [
    ({'feedback.poles': ['-4', 'x']}, r"^feedback.poles: cannot read 'x' as a pole"),
    ({'feedback.poles': [-4.0, -5.0], 'feedback.integral_poles': ['y']},
     r"^feedback.integral_poles: cannot read 'y' as a pole"),
    ({'feedback.poles': [-4.0, -5.0], 'feedback.integral_poles': [-6.0, -7.0]},
     r'^feedback.integral_poles: expected 1 poles \(one per integrated output\), got 2$'),
    ({'feedback.poles': [-4.0]}, r'^feedback.poles: expected 2 poles, got 1$'),
    ({'feedback.poles': [-4.0, 2e9]}, r'^feedback.poles: poles .* exceed 1e\+09 in magnitude'),
    ({'feedback.gain': [1.0, 2.0], 'feedback.poles': [-4.0, -5.0]},
     r'^feedback.gain: give either feedback.gain or feedback.poles, not both$'),
    ({'feedback.gain': [1.0, 2.0], 'feedback.integral_poles': [-6.0]},
     r'^feedback.integral_poles: the integral poles are placed with feedback.poles'),
    ({'feedback.integral_poles': [-6.0]},
     r'^feedback.poles: integral action needs the state feedback too'),
])
def test_the_converted_feedback_poles_are_refused_naming_their_parameter(change, message):
    with pytest.raises(ConfigError, match=message):
        validate_parameters({**SERVO, **change}, node='state_feedback')


def test_feedback_without_poles_or_gain_is_none_and_empty_poles_are_an_empty_array():
    system = validate_parameters(SERVO, node='state_feedback')
    assert system.feedback is None
    assert system.sections.feedback.poles.shape == (0,)
    assert system.sections.feedback.integral.poles.shape == (0,)


#: The wheeled base's two sources (test_sources_nodes.BASE): wheels and a late camera.
TWO_SOURCES = {
    'model.A': [0.0, 1.0, 0.0, 0.0], 'model.B': [0.0, 1.0], 'model.C': [1.0, 0.0, 0.0, 1.0],
    'model.output_names': ['camera_x', 'wheel_v'], 'observer.type': 'kalman',
    'observer.time_varying': True, 'observer.process_noise': [0.0, 1.0],
    'observer.history': 0.2, 'observer.sources': ['wheels', 'camera'],
    'sources.wheels.fields': ['velocity.wheel'], 'sources.wheels.outputs': ['wheel_v'],
    'sources.wheels.measurement_noise': [1e-2],
    'sources.camera.type': 'pose_stamped',
    'sources.camera.fields': ['pose.position.x', 'pose.position.y'],
    'sources.camera.outputs': ['camera_x', 'wheel_v'], 'sources.camera.latency': 0.05}


@pytest.mark.parametrize('sources, match', [
    ((MeasurementSource('a', (0,)), MeasurementSource('b', (0, 1))),
     r"^sources.b.outputs: output y1 is carried by sources 'a' and 'b'; each output belongs "
     r'to one source'),
    ((MeasurementSource('a', (1, 1)),),
     r"^sources.a.outputs: output y2 is named twice in source 'a'; each output belongs to "
     r'one source, once'),
    ((MeasurementSource('a', (0, 2)),), r'^sources.a.outputs: output 2 is no output of the '
     r'model \(0 ... 1'),
    ((MeasurementSource('a', ()),), r'^sources.a.outputs: expected at least one output'),
])
def test_the_cores_source_check_names_the_outputs_of_the_source_at_fault(sources, match):
    with pytest.raises(ConfigError, match=match):
        check_sources(sources, 2)


@pytest.mark.parametrize('change, message', [
    ({}, r"^sources.camera.outputs: output wheel_v is carried by sources 'wheels' and "
     r"'camera'; each output belongs to one source \(two sensors of one quantity are two "
     r'outputs\)$'),
    ({'sources.camera.outputs': ['camera_x', 'camera_x']},
     r"^sources.camera.outputs: output camera_x is named twice in source 'camera'"),
])
def test_each_output_in_one_source_is_the_cores_rule_named_by_its_parameter(change, message):
    with pytest.raises(ConfigError, match=message):
        validate_parameters({**TWO_SOURCES, **change}, node='observer')


def test_an_output_in_no_source_is_the_cores_rule_named_by_observer_sources():
    camera_only = {name: value for name, value in TWO_SOURCES.items()
                   if not name.startswith('sources.wheels.')}
    with pytest.raises(ConfigError, match=r"^observer.sources: outputs \['wheel_v'\] belong to "
                       r'no source; expected every output of the model in one source$'):
        validate_parameters({**camera_only, 'observer.sources': ['camera'],
                             'sources.camera.fields': ['pose.position.x'],
                             'sources.camera.outputs': ['camera_x']}, node='observer')


#: Sentences of the rules about sources that the core's check_sources alone says.
SOURCE_RULES = ('each output belongs to one source', 'belong to no source',
                'longer than the history', 'is named twice in source')


def test_the_rules_of_the_sources_are_written_in_the_core_alone():
    written = {}
    for path in sorted(PACKAGE.rglob('*.py')):
        text = path.read_text(encoding='utf-8')
        for sentence in SOURCE_RULES:
            if sentence in text:
                written.setdefault(sentence, []).append(path.relative_to(PACKAGE).as_posix())
    assert written == {sentence: ['core/sources.py'] for sentence in SOURCE_RULES}


#: The motor with neither observer poles, gain nor noises: no observer.
NO_OBSERVER = SERVO


def test_the_need_for_an_observer_is_one_rule_that_names_who_needs_it():
    system = validate_parameters(NO_OBSERVER)
    assert system.observer is None
    expected = (r'^observer.poles: no observer is configured: {} needs observer.poles, '
                r'observer.gain or the Kalman noise covariances$')
    with pytest.raises(ConfigError, match=expected.format('the stream')):
        system.make_stream()
    with pytest.raises(ConfigError, match=expected.format('replay')):
        load_system(system)
    with pytest.raises(ConfigError, match=expected.format('the observer node')):
        system.required_observer('the observer node')
    full = validate_parameters(MOTOR)
    assert full.required_observer('replay') is full.observer
    written = [path.relative_to(PACKAGE).as_posix() for path in sorted(PACKAGE.rglob('*.py'))
               if 'or the Kalman noise' in path.read_text(encoding='utf-8')]
    assert written == ['config/configuration.py']
