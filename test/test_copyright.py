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

"""Every source file carries the Apache-2.0 copyright header."""

from conftest import REPOSITORY

HEADER = '# Copyright 2026 observer_ros contributors'
LICENSE_LINE = 'Licensed under the Apache License, Version 2.0'


def _sources():
    for folder in ('observer_ros', 'test', 'launch', 'benchmarks', 'scripts', 'doc'):
        root = REPOSITORY / folder
        if root.exists():
            yield from sorted(root.rglob('*.py'))
            yield from sorted(root.rglob('*.sh'))
    yield REPOSITORY / 'setup.py'


def test_copyright_headers():
    missing = []
    for path in _sources():
        lines = path.read_text(encoding='utf-8').splitlines()[:6]
        body = [line for line in lines if not line.startswith('#!')]
        if not body or body[0] != HEADER or not any(LICENSE_LINE in line for line in lines):
            missing.append(str(path.relative_to(REPOSITORY)))
    assert not missing, f'files without the copyright header: {missing}'
