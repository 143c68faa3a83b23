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

"""README is the short entry point: the set-up, the CI's test command, links into doc/."""

from conftest import REPOSITORY

README = (REPOSITORY / 'README.md').read_text(encoding='utf-8')

#: About 150 lines: what it is, the set-up, a quick start, what it offers, the links.
MAX_LINES = 170


def test_ci_runs_the_readme_test_command():
    assert './scripts/test.sh' in README
    ci = (REPOSITORY / '.ci' / 'run').read_text(encoding='utf-8')
    assert 'exec ./scripts/test.sh' in ci


def test_readme_is_short_and_points_into_the_docs():
    assert len(README.splitlines()) <= MAX_LINES
    for page in ('doc/index.md', 'doc/getting_started.md', 'doc/your_own_model.md',
                 'doc/parameters.md', 'doc/nodes/index.md'):
        assert f']({page})' in README, page
