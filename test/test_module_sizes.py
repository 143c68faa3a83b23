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
One job per module: at most five modules of the package over 400 lines.

A module that grows past 400 lines is the next one to split by job (``doc/extending.md``);
the five allowed are those whose one job is long. Before issue 28, 23 were over.
"""

import pathlib

import observer_ros

#: Lines from which a module counts as large, and how many large ones the package may have.
LARGE, ALLOWED = 400, 5


def test_at_most_five_modules_are_over_400_lines():
    package = pathlib.Path(observer_ros.__file__).parent
    large = sorted((len(path.read_text().splitlines()), str(path.relative_to(package)))
                   for path in package.rglob('*.py'))
    large = [(lines, name) for lines, name in large if lines > LARGE]
    assert len(large) <= ALLOWED, large
