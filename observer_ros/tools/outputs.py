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

"""Checks that a tool's output paths can be written, made before anything is."""

from pathlib import Path

from observer_ros.bags.collection import expand_bags
from observer_ros.bags.replay_outputs import check_writable_parent
from observer_ros.bags.storage import BagError


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


__all__ = ['check_file', 'check_report_directory', 'checked_bags']
