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

"""Several bags, or folders of them, as one list: what every bag tool takes."""

from pathlib import Path
from typing import Iterable

from observer_ros.bags.storage import BagError, STORAGE_SUFFIXES


def _is_bag(path: Path) -> bool:
    """Whether ``path`` is one bag: a storage file or a directory with ``metadata.yaml``."""
    if path.is_file():
        return path.suffix in STORAGE_SUFFIXES
    return (path / 'metadata.yaml').is_file()


def expand_bags(paths: Iterable) -> list:
    """
    Return the bags named by ``paths``, in order: each a bag, or a folder of bags.

    A folder that is no bag itself (no ``metadata.yaml``) stands for the bags in it, sorted
    by name: its bag directories and storage files. A folder holding a single storage file
    and nothing else is that bag, as the readers take it.

    Raises
    ------
    BagError
        A path that does not exist, a folder without any bag, or a bag named twice.

    """
    found = []
    for given in paths:
        path = Path(given)
        if not path.exists():
            raise BagError(f'{path}: not a readable rosbag2 bag (no such file or directory)')
        if _is_bag(path) or path.is_file():
            found.append(path)
            continue
        inside = sorted(child for child in path.iterdir() if _is_bag(child))
        directories = [child for child in inside if child.is_dir()]
        if not directories and len(inside) == 1:
            found.append(path)  # a bag directory without metadata: its one storage file
        elif inside:
            found.extend(inside)
        else:
            raise BagError(f'{path}: a folder without bags (no metadata.yaml, no bag '
                           f'directories and no {" or ".join(STORAGE_SUFFIXES)} files in it)')
    names = [str(p.resolve()) for p in found]
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise BagError(f'{repeated[0]}: given more than once')
    return [str(p) for p in found]


__all__ = ['expand_bags']
