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
The configuration: typed sections bound to the schema once, parts per node, one transform.

Every parameter of the schema is one field of one section; errors are charged through the
sections' bindings; a value is checked once on its way to the estimate; a node builds only
the parts it runs; ``model.disturbances`` is one transform that owns what follows from it;
and code outside the configuration reads sections, never a parameter by its name.
"""

from dataclasses import fields
import pathlib
import re

import numpy as np
import pytest

import observer_ros
from observer_ros.config import (
    ALL_NODES, Augmentation, Configuration, node_parameters, NODE_PARTS, PARAMETERS, PARTS,
    Sections, validate_parameters)
from observer_ros.config.binding import PARAMETER, SECTION
from observer_ros.config.schema import PARAMETER_SPECS
from observer_ros.config.sections import (
    FeedbackSection, IntegralSection, ModelSection, ObserverSection, PlantSection)
from observer_ros.core import arguments, make_estimator
from observer_ros.core.arguments import (
    BOOL, DOUBLE, DOUBLE_ARRAY, INTEGER, STRING, STRING_ARRAY)
from observer_ros.core.errors import ConfigError
from observer_ros.core.poles import to_discrete
from observer_ros.core.units import NANOSECONDS

MOTOR = {'model.A': [0.0, 1.0, 0.0, -2.0], 'model.B': [0.0, 4.0], 'model.C': [1.0, 0.0],
         'model.state_names': ['q', 'q_dot'], 'model.input_names': ['effort'],
         'model.output_names': ['q'], 'observer.poles': ['-8', '-9'],
         'feedback.poles': ['-3', '-4']}
LOADED = {**MOTOR, 'model.disturbances': ['constant'], 'model.disturbance_names': ['load'],
          'observer.poles': ['-8', '-9', '-10']}

#: The Python type of each schema value type, as a section field declares it.
FIELD_TYPES = {DOUBLE: float, DOUBLE_ARRAY: list, STRING: str, STRING_ARRAY: list,
               INTEGER: int, BOOL: bool}


def test_every_parameter_is_bound_by_one_field_of_one_section():
    bound = Sections.parameter_names()
    assert len(bound) == len(set(bound))
    assert sorted(bound) == sorted(spec.name for spec in PARAMETERS)


def test_a_section_field_has_the_type_of_its_parameter():
    def check(section):
        for item in fields(section):
            if PARAMETER in item.metadata:
                spec = PARAMETER_SPECS[item.metadata[PARAMETER]]
                # a parameter with a parse is held converted (a pole list: a complex array)
                expected = np.ndarray if spec.parse is not None else FIELD_TYPES[
                    spec.value_type]
                assert item.type is expected, (section, item.name)
            elif SECTION in item.metadata and hasattr(item.metadata[SECTION], 'bindings'):
                check(item.metadata[SECTION])
    check(Sections)


def test_the_sections_hold_the_checked_values_by_the_cores_names():
    sections = Sections.check({**MOTOR, 'observer.poles': [-8, -9], 'plant.samples': 7})
    assert sections.model.A == [0.0, 1.0, 0.0, -2.0]
    poles = sections.observer.arguments['poles']  # numbers become complex, not strings
    assert poles.dtype == complex and poles.tolist() == [-8, -9]
    assert sections.parameters['observer.poles'] == ['-8', '-9']  # a parameter file's form
    assert sections.plant.samples == 7
    assert sections.topics['u_cmd'].limit == 1e9
    assert sections.feedback.integral.poles.shape == (0,)  # converted too: an empty array
    assert ObserverSection.binding()['poles'] == 'observer.poles'


def test_a_bound_argument_is_charged_to_its_own_parameter():
    integral = FeedbackSection.binding() | IntegralSection.binding()
    assert integral['poles'] == 'feedback.integral_poles'
    assert integral['gain'] == 'feedback.gain'
    assert FeedbackSection.binding()['poles'] == 'feedback.poles'
    error = ModelSection.binding().error(ConfigError('C', 'expected 1x2'), 'model.A')
    assert (error.parameter, error.reason) == ('model.C', 'expected 1x2')
    unnamed = ModelSection.binding().error(ConfigError('', 'singular'), 'model.A')
    assert (unnamed.parameter, unnamed.reason) == ('model.A', 'singular')


def test_observer_poles_are_checked_once_and_parsed_once_on_the_way_to_the_estimate(
        monkeypatch):
    checked, parsed = [], []
    coerce = arguments.Argument.coerce

    def counting_coerce(argument, value):
        checked.append(argument.name)
        return coerce(argument, value)

    import observer_ros.core.observers.common as common
    parse = common.parse_poles

    def counting_parse(entries, argument='poles'):
        parsed.append(list(entries))
        return parse(entries, argument)

    monkeypatch.setattr(arguments.Argument, 'coerce', counting_coerce)
    monkeypatch.setattr(common, 'parse_poles', counting_parse)
    configuration = validate_parameters({**MOTOR, 'feedback.poles': []}, node='observer')
    stream = configuration.make_stream()
    stream.add_input(0, [0.0])
    stream.add_measurement(10 ** 7, [0.1])
    stream.add_input(10 ** 7, [0.0])
    assert stream.add_measurement(2 * 10 ** 7, [0.2])
    assert [name for name in checked if name.endswith('poles')].count('observer.poles') == 1
    assert 'poles' not in checked  # the type takes the checked values as they are
    # each pole parameter converted once: observer.poles, feedback.poles, integral_poles
    assert parsed == [['-8', '-9'], [], []]


def test_the_continuous_observer_is_designed_again_for_each_new_interval():
    observer = validate_parameters(MOTOR, node='observer').observer
    assert observer.designs_per_interval
    estimator = observer.make_estimator()
    for interval_ns in (10_000_000, 13_000_000):
        step = estimator.step_matrices(interval_ns)
        wanted = to_discrete(observer.design.requested_poles, interval_ns / NANOSECONDS)
        assert np.allclose(np.sort_complex(step.poles), np.sort_complex(wanted))
    discrete = validate_parameters({**MOTOR, 'model.A': [1.0, 0.01, 0.0, 0.98],
                                    'model.B': [0.0, 0.04], 'model.dt': 0.01,
                                    'observer.poles': ['0.5', '0.6'],
                                    'feedback.poles': []}, node='observer')
    assert not discrete.observer.designs_per_interval


def test_make_estimator_takes_checked_values_or_arguments_not_both():
    observer = validate_parameters(MOTOR, node='observer').observer
    built = make_estimator(observer.design, values=observer.arguments)
    assert type(built) is type(observer.make_estimator())
    with pytest.raises(TypeError, match='not both'):
        make_estimator(observer.design, values=observer.arguments, method='lsq')


def test_each_node_builds_the_parts_it_runs_and_nothing_else():
    broken_observer = {**MOTOR, 'observer.poles': ['-8', '-9', '-10']}  # one pole too many
    plant = validate_parameters(broken_observer, node='plant_simulator')
    assert plant.observer is None and plant.feedback is None and plant.plant is not None
    feedback = validate_parameters(broken_observer, node='state_feedback')
    assert feedback.observer is None and feedback.feedback is not None
    with pytest.raises(ConfigError, match='^observer.poles: expected 2 poles'):
        validate_parameters(broken_observer, node='observer')
    with pytest.raises(ConfigError, match='^observer.poles: expected 2 poles'):
        validate_parameters(broken_observer)
    whole = validate_parameters(MOTOR)
    assert whole.observer and whole.feedback and whole.plant
    assert whole.loop.closed_loop_poles is not None
    assert validate_parameters(MOTOR, node='observer').loop.closed_loop_poles is None


def test_the_node_parts_are_those_whose_parameters_the_node_declares():
    sections = {'observer': ObserverSection, 'feedback': FeedbackSection,
                'plant': PlantSection}
    assert set(PARTS) == set(sections)
    for node in ALL_NODES:
        declared = {spec.name for spec in node_parameters(node)}
        uses = tuple(part for part in PARTS
                     if declared & set(sections[part].parameter_names()))
        assert uses == NODE_PARTS[node], node


def test_without_disturbances_the_transform_is_the_identity():
    transform = validate_parameters(MOTOR).augmentation
    assert transform.model is transform.plant and transform.n_disturbance_states == 0
    assert transform.disturbance_gain(False) is None
    state = np.array([1.0, 2.0])
    assert transform.simulated_state(state) is state
    poles = np.array([-1.0, -2.0])
    assert transform.loop_poles(poles) is poles and transform.cross_check
    with pytest.raises(ConfigError, match='^plant.disturbance: the model has no disturb'):
        transform.disturbance_step([1.0])


def test_the_disturbance_transform_owns_what_follows_from_it():
    configuration = validate_parameters({**LOADED, 'feedback.disturbance_rejection': True,
                                         'plant.initial_state': [0.5, 0.0],
                                         'plant.process_noise': [0.1, 0.2],
                                         'plant.disturbance': [0.3]})
    transform = configuration.augmentation
    assert isinstance(transform, Augmentation) and configuration.model.n_states == 3
    assert configuration.model.state_names == ('q', 'q_dot', 'load')
    # The plant is padded, and stepped by plant.disturbance.
    assert configuration.plant.initial_state.tolist() == [0.5, 0.0, 0.0]
    assert configuration.plant.process_noise == [0.1, 0.0, 0.0, 0.0, 0.2, 0.0, 0.0, 0.0, 0.0]
    assert configuration.plant.disturbance.tolist() == [0.3]
    # K acts on the plant, K_d cancels the matched load.
    assert configuration.feedback.design.gain.shape == (1, 2)
    assert configuration.feedback.disturbance_gain.tolist() == [[1.0]]
    # The generator's mode (s = 0) is not a pole of the real loop, and G_oc is not
    # cross-checked with a Diophantine equation that does not apply.
    assert len(configuration.loop.closed_loop_poles) == 2 + 3
    assert not transform.cross_check
    assert not [note for note in configuration.loop.notes if 'cross-checked' in note]


#: Rooms outside the configuration, which read sections and settings.
READERS = ('nodes', 'ros', 'bags', 'tools', 'app')


def test_code_outside_the_configuration_reads_no_parameter_by_its_name():
    root = pathlib.Path(observer_ros.__file__).parent
    raw = re.compile(r"parameters\[|params\[['f]")
    found = [f'{path.relative_to(root)}:{number}: {line.strip()}'
             for room in READERS for path in sorted((root / room).rglob('*.py'))
             for number, line in enumerate(path.read_text().splitlines(), 1)
             if raw.search(line)]
    assert found == []


def test_the_configuration_answers_what_the_other_code_asks():
    configuration = validate_parameters(MOTOR)
    assert isinstance(configuration, Configuration)
    assert configuration.model.n_states == 2
    assert configuration.observer.design.kind == 'full_order'
    assert configuration.feedback.design.gain.shape == (1, 2)
    assert configuration.plant.rate_hz == 100.0
    assert configuration.sample_rate_hz == 100.0
    assert configuration.parameters['observer.poles'] == ['-8', '-9']
    assert configuration.make_stream().estimator.n_states == 2
    with pytest.raises(ConfigError, match='^observer.poles: no observer is configured'):
        validate_parameters(MOTOR, node='plant_simulator').make_stream()


def test_the_bindings_and_the_settings_by_name_are_one_read_only_mapping():
    from observer_ros.config import binding as bindings, topic_sections
    for kind in (bindings.Binding, topic_sections.SettingsByName,
                 topic_sections.TopicsSection, topic_sections.SourcesSection):
        assert issubclass(kind, bindings.ReadOnlyMapping)
        for method in ('__init__', '__getitem__', '__iter__', '__len__'):
            assert getattr(kind, method) is getattr(bindings.ReadOnlyMapping, method), (
                kind, method)
    given = {'poles': 'observer.poles'}
    binding = bindings.Binding(given)
    given['gain'] = 'observer.gain'  # a copy: the caller's dict changes nothing
    assert dict(binding) == {'poles': 'observer.poles'} and len(binding) == 1
    joined = binding | {'gain': 'feedback.gain'}
    assert dict(joined) == {'poles': 'observer.poles', 'gain': 'feedback.gain'}
    with pytest.raises(TypeError):
        binding['poles'] = 'feedback.poles'
