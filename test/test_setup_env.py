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

"""``source scripts/setup_env.sh`` leaves the caller's shell options as they were."""

import hashlib
import os
from pathlib import Path
import subprocess
import sys

import pytest

from conftest import REPOSITORY


def pip_setup() -> bool:
    """Whether this interpreter is the repository's ``.venv``, installed as now."""
    stamp = REPOSITORY / '.venv' / '.observer_ros_installed'
    if Path(sys.prefix) != REPOSITORY / '.venv' or not stamp.exists():
        return False
    wanted = hashlib.sha256(b''.join((REPOSITORY / name).read_bytes()
                                     for name in ('requirements.txt', 'setup.py')))
    return stamp.read_text(encoding='utf-8').strip() == wanted.hexdigest()


@pytest.mark.skipif(not pip_setup(), reason='needs the .venv of scripts/setup_env.sh, '
                    'installed as now (sourcing it would install)')
def test_a_shell_that_sources_the_set_up_survives_a_failing_command():
    # It used to leave set -euo pipefail in the caller's shell, which then closed on the
    # first failing command.
    script = ('before="$-"; source scripts/setup_env.sh && [ "$-" = "$before" ] '
              '&& echo same options; false; '
              'echo "survived $(set -o | grep -cE "(errexit|nounset|pipefail) +on")"; '
              'command -v python')
    env = {key: value for key, value in os.environ.items() if key != 'OBSERVER_ROS_VENV'}
    result = subprocess.run(['bash', '-c', script], cwd=REPOSITORY, capture_output=True,
                            text=True, timeout=120, env=env)
    lines = result.stdout.splitlines()
    assert lines[:2] == ['same options', 'survived 0'], (result.stdout, result.stderr)
    assert lines[2] == str(REPOSITORY / '.venv' / 'bin' / 'python')
