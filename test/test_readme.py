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

"""README stays in step with the code: commands, CI and the parameter schema."""

import re

from conftest import console_scripts, REPOSITORY
from observer_ros.config import parameter_table, PARAMETERS

README = (REPOSITORY / 'README.md').read_text(encoding='utf-8')


def test_every_parameter_is_documented_with_its_default():
    for spec in PARAMETERS:
        assert f'| `{spec.name}` |' in README, spec.name


def test_parameter_table_is_the_generated_one():
    # Regenerate with: python -c "from observer_ros.config import parameter_table as t;
    # print(t())" and paste it over README's table.
    assert parameter_table() in README


def test_ci_runs_the_readme_test_command():
    assert './scripts/test.sh' in README
    ci = (REPOSITORY / '.ci' / 'run').read_text(encoding='utf-8')
    assert 'exec ./scripts/test.sh' in ci


def test_every_shipped_config_is_listed():
    for path in (REPOSITORY / 'config').glob('*.yaml'):
        assert path.name in README, path.name


def test_every_executable_is_documented():
    for name in console_scripts():
        assert f'`{name}`' in README, name


def test_every_test_readme_cites_exists():
    defined = set()
    for path in (REPOSITORY / 'test').glob('test_*.py'):
        defined.update(re.findall(r'^def (test_\w+)', path.read_text(encoding='utf-8'), re.M))
    cited = set(re.findall(r'`(test_\w+)`', README))
    assert cited and cited <= defined, sorted(cited - defined)
