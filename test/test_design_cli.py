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

"""The design CLI and the parameter schema, on every shipped config and on bad input."""

import json
import re
import subprocess

import numpy as np
import pytest

from conftest import CONFIG_DIR, console_script
from observer_ros.config import load_parameter_file, PARAMETERS, validate_parameters
from observer_ros.core.errors import ConfigError


def run_cli(*args):
    return subprocess.run([console_script('design_observer'), *map(str, args)],
                          capture_output=True, text=True, timeout=60)


def design_json(path):
    result = run_cli('--json', path)
    assert result.returncode == 0, result.stderr
    return json.loads(result.stdout)


def complex_list(pairs):
    return np.array([complex(re, im) for re, im in pairs])


@pytest.mark.parametrize('path', sorted(CONFIG_DIR.glob('*.yaml')), ids=lambda p: p.name)
def test_every_shipped_config_designs(path):
    summary = design_json(path)
    assert summary['observer.gain'] or summary['observer.type'] == 'kalman'
    assert summary['model']['observable']
    poles = complex_list(summary['observer.poles'])
    assert np.all(poles.real < 0)
    if 'closed_loop_poles' in summary:
        assert np.all(complex_list(summary['closed_loop_poles']).real < 0)


def test_seed000_reduced_order_gain():
    summary = design_json(CONFIG_DIR / 'seed000_reduced_order.yaml')
    np.testing.assert_allclose(np.ravel(summary['observer.gain']), [0.5, 0.5], atol=1e-12)


def test_seed001_third_order():
    summary = design_json(CONFIG_DIR / 'seed001_third_order.yaml')
    np.testing.assert_allclose(np.ravel(summary['feedback.gain']), [1.25, 1.25, 0.19375],
                               atol=1e-12)
    np.testing.assert_allclose(np.ravel(summary['observer.gain']), [10, -24], atol=1e-10)
    tf = summary['controller_tf']
    np.testing.assert_allclose(tf['num'], [9.1, 73.5, 125], rtol=1e-10)
    np.testing.assert_allclose(tf['den'], [1, 17, -30], rtol=1e-10)
    assert tf['unstable']
    np.testing.assert_allclose(summary['controller_tf_diophantine']['num'], tf['num'],
                               rtol=1e-9)
    np.testing.assert_allclose(summary['controller_tf_diophantine']['den'], tf['den'],
                               rtol=1e-9)
    assert any('unstable on its own' in note for note in summary['notes'])
    closed = np.sort_complex(complex_list(summary['closed_loop_poles']))
    expected = np.sort_complex(np.array([-10, -10, -5, -1 - 2j, -1 + 2j]))
    np.testing.assert_allclose(closed, expected, atol=1e-6)


def test_seed001_chen_controller_matches_the_seed():
    summary = design_json(CONFIG_DIR / 'seed001_third_order_chen.yaml')
    tf = summary['controller_tf']
    assert tf['gain'] == pytest.approx(11.6, rel=1e-9)
    np.testing.assert_allclose(sorted(z[0] for z in tf['zeros']), [-5.593, -2.312], atol=1e-3)
    np.testing.assert_allclose(sorted(p[0] for p in tf['poles']), [-20.96, 1.956], atol=1e-2)


def test_seed001_fourth_order_observability_coordinates():
    summary = design_json(CONFIG_DIR / 'seed001_fourth_order.yaml')
    np.testing.assert_allclose(np.ravel(summary['observer.gain']), [23, 117.75, -347],
                               rtol=1e-12)


def test_seed003_full_order_gain():
    summary = design_json(CONFIG_DIR / 'seed003_full_order.yaml')
    np.testing.assert_allclose(np.ravel(summary['observer.gain']), [22, 59], rtol=1e-12)


def test_seed004_error_spec_accepts_poles_at_or_left_of_bound(tmp_path):
    summary = design_json(CONFIG_DIR / 'seed004_error_spec.yaml')
    assert max(p[0] for p in summary['observer.poles']) == pytest.approx(-2.0)
    params = load_parameter_file(CONFIG_DIR / 'seed004_error_spec.yaml')
    params['observer.poles'] = ['-1.3', '-3', '-4']
    with pytest.raises(ConfigError, match=r'observer\.poles.*slower.*-1\.3815'):
        validate_parameters(params)
    params['observer.poles'] = []
    generated = validate_parameters(params).observer.design.requested_poles
    assert generated.real.max() == pytest.approx(np.log(1e-3) / 5.0)


def test_write_round_trip(tmp_path):
    written = tmp_path / 'designed.yaml'
    result = run_cli(CONFIG_DIR / 'seed001_third_order.yaml', '--write', written)
    assert result.returncode == 0, result.stderr
    assert '9.1 s^2 + 73.5 s + 125' in result.stdout
    again = design_json(written)
    assert again['observer.method'] == 'given'
    assert again['feedback.method'] == 'given'
    np.testing.assert_allclose(np.ravel(again['observer.gain']), [10, -24], atol=1e-10)
    np.testing.assert_allclose(again['controller_tf']['den'], [1, 17, -30], rtol=1e-9)
    assert 'rate_hz' not in written.read_text() or '100.0' in written.read_text()


BAD_CASES = [
    ('model: {A: [0.0, 1.0, 0.0, 0.0], B: [0.0, 1.0, 1.0], C: [1.0, 0.0]}',
     r'model\.B: expected 2xm'),
    ('model: {A: [0.0, 1.0, 0.0], B: [0.0, 1.0], C: [1.0, 0.0]}', r'model\.A: expected a square'),
    ('model: {A: [0.0, .nan, 0.0, 0.0], B: [0.0, 1.0], C: [1.0, 0.0]}',
     r'model\.A: expected finite numbers, entry 1 is nan'),
    ('model: {A: [1.0, 0.0, 0.0, 2.0], B: [1.0, 1.0], C: [1.0, 0.0]}\n'
     "    observer: {poles: ['-1', '-2']}", r'observer\.poles: \(A, C\) is not observable: the '
     r'modes 2 cannot'),
    ('model: {A: [0.0, 1.0, 0.0, 0.0], B: [0.0, 1.0], C: [1.0, 0.0]}\n'
     '    observer: {gain: [-1.0, 1.0]}', r'observer\.gain: the given gain makes the observer '
     r'error unstable'),
    ('model: {A: [0.0, 1.0, 0.0, 0.0], B: [0.0, 1.0], C: [1.0, 0.0]}\n'
     "    observer: {poles: ['-1+1j', '-2']}", r'observer\.poles: complex pole \(-1\+1j\) has '
     r'no conjugate'),
    ('model: {A: [0.0, 1.0, 0.0, 0.0], B: [0.0, 1.0], C: [1.0, 0.0]}\n'
     "    observer: {poles: ['-1', '-2', '-3']}", r'observer\.poles: expected 2 poles'),
    ('model: {A: [0.0, 1.0, 0.0, 0.0], B: [0.0, 1.0], C: [1.0, 0.0]}\n'
     "    feedbak: {poles: ['-1', '-2']}", r'feedbak\.poles: unknown parameter'),
    ('model: {A: [1.0, 0.0, 0.0, 2.0], B: [1.0, 0.0], C: [1.0, 1.0]}\n'
     "    feedback: {poles: ['-1', '-2']}", r'feedback\.poles: \(A, B\) is not controllable: '
     r'the modes 2 cannot be moved'),
    ('model: {A: [0.0, 1.0, 0.0, 0.0], B: [0.0, 1.0], C: [1.0, 0.0]}\n'
     "    observer: {type: 'luenberger'}", r'observer\.type: expected one of full_order'),
    ('model: {A: [0.0, 1.0, 0.0, 0.0], B: [0.0, 1.0], C: [1.0, 0.0]}\n'
     "    observer: {poles: ['-1', '-2'], interval_resolution: -1.0e-5}",
     r'observer\.interval_resolution: expected seconds in \[0, 1e\+06\], got -1e-05'),
    ('model: {A: [0.0, 1.0, 0.0, 0.0], B: [0.0, 1.0], C: [1.0, 0.0]}\n'
     "    observer: {poles: ['-1', '-2'], interval_resolution: 2.0}",
     r'observer\.interval_resolution: expected seconds in \[0'),
    ('model: {A: [0.5, 1.0, 0.0, 0.5], B: [0.0, 1.0], C: [1.0, 0.0], dt: 0.01}\n'
     "    observer: {poles: ['0.1', '0.2'], interval_resolution: 1.0e-5}",
     r'observer\.interval_resolution: a discrete model \(model\.dt = 0\.01\) has one '
     r'period; expected 0'),
]


@pytest.mark.parametrize('body,message', BAD_CASES)
def test_bad_configuration_exits_2_with_one_clear_line(tmp_path, body, message):
    path = tmp_path / 'bad.yaml'
    path.write_text('/**:\n  ros__parameters:\n    ' + body + '\n')
    result = run_cli(path)
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith('design_observer: error: ')
    assert re.search(message, lines[0]), lines[0]


def test_unreadable_and_sectionless_files(tmp_path):
    assert 'cannot read parameter file' in run_cli(tmp_path / 'missing.yaml').stderr
    path = tmp_path / 'plain.yaml'
    path.write_text('model: {A: [1.0]}\n')
    assert 'no "/**: ros__parameters:" section' in run_cli(path).stderr


def test_integers_are_accepted_from_users():
    system = validate_parameters({'model.A': [0, 1, 0, 0], 'model.B': [0, 1],
                                  'model.C': [1, 0], 'observer.poles': [-5, -6]})
    np.testing.assert_allclose(
        np.sort(np.linalg.eigvals(system.model.a - system.observer.design.gain @ system.model.c)),
        [-6, -5])


def test_every_parameter_is_described_and_matrices_say_row_major():
    for spec in PARAMETERS:
        assert spec.description.endswith('.'), spec.name
        if spec.name in ('model.A', 'model.B', 'model.C', 'model.D', 'observer.gain',
                         'feedback.gain', 'feedback.reference_gain'):
            assert 'row-major' in spec.description, spec.name


def test_a_discrete_model_without_a_plant_section_runs_at_its_own_rate(tmp_path):
    # before: "plant.rate_hz: a discrete model with model.dt = 0.1 s runs at 10 Hz, got 100.0"
    path = tmp_path / 'discrete.yaml'
    path.write_text('/**:\n  ros__parameters:\n'
                    '    model: {A: [1.0, 0.1, 0.0, 1.0], B: [0.005, 0.1], C: [1.0, 0.0], '
                    'dt: 0.1}\n'
                    "    observer: {poles: ['0.5', '0.6']}\n")
    result = run_cli(path, '--json')
    assert result.returncode == 0, result.stderr
    system = validate_parameters(load_parameter_file(str(path)))
    assert system.plant.rate_hz == pytest.approx(10.0)
    assert json.loads(result.stdout)['observer.type'] == 'full_order'


@pytest.mark.parametrize('kind', ['full_order', 'reduced_order', 'chen', 'kalman'])
def test_a_model_with_a_feedthrough_designs_and_says_so(tmp_path, kind):
    # Exited 2 before ("D: the runtime estimators need D = 0"); the separation principle
    # holds with D, and the Diophantine cross-check of G_oc (made with D) agrees.
    text = (CONFIG_DIR / 'seed001_third_order.yaml').read_text()
    text = text.replace('      C: [1.0, 0.0, 0.0]\n', '      C: [1.0, 0.0, 0.0]\n      D: [0.5]\n')
    text = text.replace("type: 'reduced_order'", f"type: '{kind}'")
    if kind == 'kalman':
        text = text.replace("      poles: ['-10', '-10']\n",
                            '      process_noise: [0.1, 0.1, 0.1]\n'
                            '      measurement_noise: [0.01]\n')
    elif kind == 'full_order':
        text = text.replace("poles: ['-10', '-10']", "poles: ['-10', '-11', '-12']")
    path = tmp_path / f'{kind}.yaml'
    path.write_text(text)
    result = run_cli(path)
    assert result.returncode == 0, result.stderr
    assert 'Feedthrough D (y = C x + D u' in result.stdout
    summary = design_json(path)
    assert summary['model']['feedthrough'] == [[0.5]]
    loop = np.sort_complex(complex_list(summary['closed_loop_poles']))
    expected = np.sort_complex(np.concatenate([complex_list(summary['feedback.poles']),
                                               complex_list(summary['observer.poles'])]))
    np.testing.assert_allclose(loop, expected, atol=1e-6)
    for key in ('num', 'den'):
        np.testing.assert_allclose(summary['controller_tf'][key],
                                   summary['controller_tf_diophantine'][key], rtol=1e-6)
