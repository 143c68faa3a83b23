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

"""The benchmark suite runs end to end on tiny sizes and writes a complete report."""

import re
import shutil
import subprocess
import sys

import pytest

from conftest import REPOSITORY


def test_smoke_run_writes_every_section_and_figure(tmp_path):
    # The options that shorten the real-time runs, at the smoke sizes.
    result = subprocess.run([sys.executable, '-m', 'benchmarks.run', '--smoke', '--runs', '1',
                             '--seconds', '0.5', '--rounds', '10', '--output', str(tmp_path)],
                            cwd=REPOSITORY, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    report = (tmp_path / 'BENCHMARKS.md').read_text(encoding='utf-8')
    headings = re.findall(r'^## (\d+)\. ', report, flags=re.MULTILINE)
    assert headings == [str(n) for n in range(1, 11)]
    assert '(smoke run)' in report
    figures = re.findall(r'!\[[^]]*\]\(([^)]+)\)', report)
    assert len(figures) == 6
    for figure in figures:
        assert (tmp_path / figure).stat().st_size > 1000, figure
    # The controller's latency row and the set-ups of the closed loop, worst run shown.
    assert '| controller p50 | controller p99 |' in report
    assert '0.5 s per run, 1 run per rate' in report
    for setup in ('one process, controller', 'two processes', 'three processes'):
        for executor in ('single', 'events'):
            assert f'{setup}, {executor} |' in report, (setup, executor)
    # Every table row is complete: no section lost its numbers.
    for line in report.splitlines():
        if line.startswith('| ') and 'design refused' not in line:
            assert 'nan' not in line.lower(), line


def only(sections: str, output) -> str:
    """Run ``benchmarks.run --smoke --only`` into ``output``; return the report."""
    result = subprocess.run([sys.executable, '-m', 'benchmarks.run', '--smoke', '--only',
                             sections, '--output', str(output)], cwd=REPOSITORY,
                            capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr[-2000:]
    return (output / 'BENCHMARKS.md').read_text(encoding='utf-8')


@pytest.fixture(scope='module')
def section_6_alone(tmp_path_factory):
    """Write a report of section 6 (noise) alone, once for the two tests of --only."""
    output = tmp_path_factory.mktemp('only_6')
    return output, only('6', output)


def test_only_runs_the_chosen_sections(section_6_alone):
    _, report = section_6_alone
    assert re.findall(r'^## (\d)\. ', report, flags=re.MULTILINE) == ['6']
    assert 'Kalman MSE / trace(P)' in report and 'ratio **' in report


def test_only_keeps_the_other_sections_of_an_existing_report(section_6_alone, tmp_path):
    # Two of the quick sections (6: noise, written by the fixture, then 1: design over it;
    # 7 takes four times as long as 1). One run less than writing both here.
    output, _ = section_6_alone
    shutil.copytree(output, tmp_path, dirs_exist_ok=True)
    report = only('1', tmp_path)
    assert re.findall(r'^## (\d)\. ', report, flags=re.MULTILINE) == ['1', '6']
    assert re.findall(r'^\| (\d)\. ', report, flags=re.MULTILINE) == ['1', '6']
    assert 'Kept from an earlier run: sections 6.' in report


def test_the_bag_worker_benchmark_runs_and_finds_one_estimate():
    result = subprocess.run([sys.executable, '-m', 'benchmarks.bag_workers', '--bags', '2',
                             '--samples', '1000', '--workers', '1'], cwd=REPOSITORY,
                            capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    assert '| 1 local | ' in result.stdout
    assert 'tuned Q and R equal across runs: True' in result.stdout
