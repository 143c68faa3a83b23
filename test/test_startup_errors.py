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
Start-up errors of the nodes: one line and exit status 2, as the tools give them.

A params file that rcl would refuse (missing, a list mixing ``0`` and ``1.0``) is read
first; ``design_observer`` refuses the same file with the same text; a misspelt parameter
names the nearest valid ones and the page that lists them.
"""

import subprocess

import pytest

from conftest import CONFIG_DIR, console_script
from observer_ros.config import load_parameter_file, validate_parameters
from observer_ros.core.errors import ConfigError
from observer_ros.nodes.closed_loop import main as closed_loop_main
from observer_ros.nodes.main import observer as observer_main
from observer_ros.nodes.main import plant_simulator as plant_main
from observer_ros.tools.design_observer import main as design_main

MIXED = ('model.A: a list mixing integers and floats ([2, 3.0, -1.0, 4.0]): the ROS parameter '
         'loader refuses it; write every value as a float (2.0, not 2)')


@pytest.fixture
def mixed_file(tmp_path):
    path = tmp_path / 'mixed.yaml'
    path.write_text((CONFIG_DIR / 'seed003_full_order.yaml').read_text().replace(
        'A: [2.0, 3.0,', 'A: [2, 3.0,', 1))
    return path


@pytest.mark.parametrize('main,program', [(observer_main, 'observer'),
                                          (plant_main, 'plant_simulator'),
                                          (closed_loop_main, 'closed_loop')])
def test_a_missing_or_mixed_params_file_is_one_line_and_exit_2(main, program, mixed_file,
                                                               tmp_path, capsys):
    missing = tmp_path / 'missing.yaml'
    assert main([program, '--ros-args', '--params-file', str(missing)]) == 2
    assert capsys.readouterr().err == (f'{program}: error: cannot read parameter file '
                                       f'{missing}: No such file or directory\n')
    assert main([program, '--ros-args', '--params-file', str(mixed_file)]) == 2
    assert capsys.readouterr().err == f'{program}: error: {MIXED} (in {mixed_file})\n'
    assert main([program, '--ros-args', '-p', 'model.A:=[0, 1.0]']) == 2
    err = capsys.readouterr().err
    assert err.startswith(f'{program}: error: ') and err.count('\n') == 1, err
    assert 'Sequence should be of same type' in err and '.c:' not in err


def test_the_node_process_prints_one_line_without_a_traceback(tmp_path):
    result = subprocess.run([console_script('observer'), '--ros-args', '--params-file',
                             str(tmp_path / 'missing.yaml')],
                            capture_output=True, text=True, timeout=60)
    assert result.returncode == 2
    assert result.stderr.splitlines() == [
        f'observer: error: cannot read parameter file {tmp_path / "missing.yaml"}: No such '
        f'file or directory']


def test_design_observer_refuses_the_file_the_nodes_refuse(mixed_file, capsys):
    assert design_main([str(mixed_file)]) == 2
    assert capsys.readouterr().err == f'design_observer: error: {MIXED} (in {mixed_file})\n'
    with pytest.raises(ConfigError, match=r'^model\.A: a list mixing'):
        load_parameter_file(str(mixed_file))


@pytest.mark.parametrize('name,nearest', [
    ('observer.polse', "did you mean 'observer.poles'?"),
    ('plant.rate', "did you mean 'plant.rate_hz'?"),
    ('model.a', "did you mean 'model.A'?"),
    ('observer.clock_tolerence', "did you mean 'observer.clock_tolerance'?"),
])
def test_a_misspelt_parameter_names_the_nearest_and_the_page(name, nearest):
    params = load_parameter_file(str(CONFIG_DIR / 'seed003_full_order.yaml'))
    with pytest.raises(ConfigError) as raised:
        validate_parameters({**params, name: 1.0}, strict=True)
    assert str(raised.value) == (f'{name}: unknown parameter; {nearest} (every parameter: '
                                 f'doc/parameters.md)')
