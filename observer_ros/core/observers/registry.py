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
The registry of observer types, filled from the entry-point group on first use.

Every type, the built-in ones included, is an entry point of the group :data:`GROUP` whose
object is an :class:`~observer_ros.core.observers.ObserverType` (or a callable returning
one). The group is loaded once, the way colcon-core loads its extensions: each entry point
on its own (one that fails is recorded and reported, naming the entry point, and the others
still load), then ordered by priority (highest first) and name.
"""

from importlib.metadata import entry_points
import threading
import warnings

from observer_ros.core.errors import ConfigError

#: The entry-point group of the observer types.
GROUP = 'observer_ros.observer_types'


class PluginLoadWarning(UserWarning):
    """An entry point of :data:`GROUP` could not be loaded (its type is not available)."""


_LOCK = threading.RLock()
_TYPES: dict = {}
_ARGUMENTS: dict = {}
_FAILED: dict = {}
_STATE = {'loaded': False}


def _entry_point_text(entry_point) -> str:
    source = getattr(getattr(entry_point, 'dist', None), 'name', None)
    where = f' (distribution {source})' if source else ''
    return f'entry point {entry_point.name!r} = {entry_point.value}{where} of {GROUP}'


def _loaded_type(entry_point):
    """Return the type an entry point names, or raise saying what is wrong with it."""
    from observer_ros.core.observers import ObserverType  # the package imports this module
    kind = entry_point.load()
    if not isinstance(kind, ObserverType) and callable(kind):
        kind = kind()
    if not isinstance(kind, ObserverType):
        raise TypeError(f'expected an ObserverType (or a callable returning one), got '
                        f'{type(kind).__name__}')
    if kind.name != entry_point.name:
        raise ValueError(f'the entry point is named {entry_point.name!r} but its type '
                         f'{kind.name!r}')
    return kind


def _fail(entry_point, error: Exception) -> None:
    text = (f'{_entry_point_text(entry_point)} failed to load: '
            f'{type(error).__name__}: {error}')
    _FAILED[entry_point.name] = text
    warnings.warn(text, PluginLoadWarning, stacklevel=3)


def load() -> None:
    """Load the entry points of :data:`GROUP` into the registry (once; later calls return)."""
    with _LOCK:
        if _STATE['loaded']:
            return
        _STATE['loaded'] = True
        found = []
        for entry_point in entry_points(group=GROUP):
            try:
                kind = _loaded_type(entry_point)
            except Exception as e:  # noqa: B902 - any failure of a plug-in is reported
                _fail(entry_point, e)
                continue
            found.append((entry_point, kind))
        for entry_point, kind in sorted(found, key=lambda item: (-item[1].priority,
                                                                 item[1].name)):
            if _TYPES.get(kind.name) is kind:
                continue  # the same type found twice (two copies of one distribution)
            try:
                add(kind)
            except ValueError as e:
                _fail(entry_point, e)


def add(kind) -> None:
    """
    Add ``kind`` to the registry.

    Raises
    ------
    ValueError
        A type of that name is registered already, or an argument clashes.

    """
    with _LOCK:
        if kind.name in _TYPES:
            raise ValueError(f'observer type {kind.name!r} is registered already')
        for argument in kind.arguments:
            known = _ARGUMENTS.get(argument.name)
            if known is not None and known != argument:
                raise ValueError(f'observer type {kind.name!r}: argument {argument.name!r} '
                                 f'differs from the one another type declares')
        for argument in kind.arguments:
            _ARGUMENTS[argument.name] = argument
        _TYPES[kind.name] = kind


def find(name: str):
    """
    Return the registered type called ``name``.

    Raises
    ------
    ConfigError
        ``type``: a plug-in of that name failed to load (the message says why), or no type
        has that name (the message lists the registered ones).

    """
    kind = _TYPES.get(name)
    if kind is not None:
        return kind
    if name in _FAILED:
        raise ConfigError('type', f'observer type {name!r} is not available: {_FAILED[name]}')
    known = ', '.join(_TYPES) or (f'none: the entry-point group {GROUP} is empty (install '
                                  f'observer_ros: pip install -e . or colcon build)')
    raise ConfigError('type', f'expected one of {known}, got {name!r}')


def types() -> tuple:
    """Return the registered types, in registry order."""
    return tuple(_TYPES.values())


def arguments() -> tuple:
    """Return every argument of every registered type, each once."""
    return tuple(_ARGUMENTS.values())


def failures() -> dict:
    """Return ``{entry point name: why it failed to load}``."""
    return dict(_FAILED)


def types_and_failures() -> tuple:
    """Return the names of the registered types, then those of the failed entry points."""
    return tuple(_TYPES) + tuple(name for name in _FAILED if name not in _TYPES)
