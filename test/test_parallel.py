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

"""The bag tools' task mapper: order, worker count, progress bar only on a terminal."""

import io

import pytest

from observer_ros.app.parallel import Progress, task_mapper


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_results_come_back_in_task_order_with_a_bar_on_a_terminal_only():
    terminal, pipe = Terminal(), io.StringIO()
    with task_mapper(workers=1, stream=terminal) as mapper:
        assert mapper(abs, [-3, 2, -1], 'bags') == [3, 2, 1]
    with task_mapper(workers=1, stream=pipe) as mapper:
        assert mapper(abs, [-1], 'bags') == [1]
    assert '\rbags [' in terminal.getvalue() and '3/3' in terminal.getvalue()
    assert terminal.getvalue().endswith('\n') and pipe.getvalue() == ''
    bar = Progress(4, 'replay', io.StringIO(), force=True)
    bar.advance(2)
    assert '#' * 15 + '.' * 15 + '] 2/4' in bar.stream.getvalue()


def test_a_worker_count_below_one_is_refused():
    with pytest.raises(ValueError, match='--workers: expected at least 1, got 0'):
        task_mapper(workers=0)
