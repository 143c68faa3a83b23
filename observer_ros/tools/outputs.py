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

import os
from pathlib import Path

from observer_ros.bags.replay_outputs import missing_parents
from observer_ros.bags.storage import BagError


def _writable_parent(option: str, path: Path) -> None:
    missing = missing_parents(path)
    existing = (missing[-1] if missing else path.absolute()).parent
    if not existing.is_dir():
        raise BagError(f'{option}: {existing} is not a directory')
    if not os.access(existing, os.W_OK | os.X_OK):
        raise BagError(f'{option}: cannot write in {existing}')


def check_file(option: str, path) -> None:
    """Refuse a file output that is a directory or lands where nothing can be written."""
    path = Path(path)
    if path.is_dir():
        raise BagError(f'{option}: {path} is a directory; give a file name')
    _writable_parent(option, path)


def check_report_directory(path, option: str = '--report') -> None:
    """Refuse a report directory that is a file or cannot be created."""
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise BagError(f'{option}: {path} is a file; give a directory')
    _writable_parent(option, path)


__all__ = ['check_file', 'check_report_directory']
