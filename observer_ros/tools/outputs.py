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

"""The offline tools' common ends: output paths checked before anything is made, one run shape."""

from pathlib import Path
import sys
from typing import Callable, Optional

from observer_ros.bags.collection import expand_bags
from observer_ros.bags.replay_outputs import (
    check_writable_parent, made_directories, remove_outputs)
from observer_ros.bags.storage import BagError
from observer_ros.core.errors import ConfigError, DesignError


def check_file(option: str, path) -> None:
    """Refuse a file output that is a directory or lands where nothing can be written."""
    path = Path(path)
    if path.is_dir():
        raise BagError(f'{option}: {path} is a directory; give a file name')
    check_writable_parent(option, path)


def check_report_directory(path, option: str = '--report') -> None:
    """Refuse a report directory that is a file or cannot be created."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise BagError(f'{option}: {path} is a file; give a directory')
    check_writable_parent(option, path)


def checked_bags(options) -> list:
    """Check ``options.output`` (a file) and ``options.report`` (a directory); expand the bags."""
    if options.output:
        check_file('--output', options.output)
    if options.report:
        check_report_directory(options.report)
    return expand_bags(options.bags)


#: Exit status of an error (one line on stderr, nothing written).
ERROR_STATUS = 2


def run_tool(tool: str, options, compute: Callable[[list], tuple],
             write_output: Callable, output_label: str, write_report: Callable,
             failed_checks: Optional[Callable[[object], list]] = None,
             accept_option: str = '', failed_status: int = ERROR_STATUS) -> int:
    """
    Run a bag tool: check its outputs, compute, write; one error line and status 2 on failure.

    ``compute(bags)`` returns ``(result, text)``; ``write_output(result, text)`` writes
    ``options.output``; ``write_report(result, text)`` writes the report and returns its
    path. The output paths are checked before any bag is read; the folders they need are
    made after the work (as ``replay`` makes those of its outputs), and an output that then
    cannot be written is an error naming its option and path that leaves nothing behind. An
    error with an ``exit_status`` attribute exits with that status instead of 2.

    ``failed_checks(result)`` lists the tool's own checks that the result failed: then
    ``options.output`` is not written, a line on stderr says so and the tool exits with
    ``failed_status``, unless the option ``accept_option`` (``--accept-failed-checks``) was
    given. The report is written either way.
    """
    written, made = [], []
    try:
        bags = checked_bags(options)
        result, text = compute(bags)
        failed = failed_checks(result) if failed_checks else []
        accepted = bool(accept_option) and getattr(
            options, accept_option.lstrip('-').replace('-', '_'))
        refused = bool(failed) and not accepted
        output = options.output if not refused else None
        made = made_directories(output, options.report and Path(options.report) / tool)
        for directory in reversed(made):  # shallowest first
            directory.mkdir(exist_ok=True)
        if output:
            _written('--output', options.output, write_output, result, text)
            written.append(Path(options.output))
        report = None
        if options.report:
            report = _written('--report', options.report, write_report, result, text)
    except (BagError, ConfigError, DesignError, ValueError, OSError) as e:
        remove_outputs(written, made)
        print(f'{tool}: error: {e}', file=sys.stderr)
        return getattr(e, 'exit_status', ERROR_STATUS)
    print(text)
    if options.output:
        print(f'{output_label}: {options.output}' if not refused else
              f'{output_label}: not written ({accept_option} writes it anyway)')
    if report is not None:
        print(f'report: {report}')
    if refused:
        print(f'{tool}: failed its checks (exit status {failed_status}): '
              + '; '.join(failed), file=sys.stderr)
        return failed_status
    return 0


def _written(option: str, path, write: Callable, result, text: str):
    """Call ``write(result, text)``; an OSError becomes a BagError naming the option and path."""
    try:
        return write(result, text)
    except OSError as e:
        raise BagError(f'{option}: cannot write {path}: {e.strerror or e}') from e


__all__ = ['ERROR_STATUS', 'check_file', 'check_report_directory', 'checked_bags', 'run_tool']
