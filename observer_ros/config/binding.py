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
Which parameter each section field and each core argument stands for.

A section is a frozen dataclass whose fields are bound to the schema's parameters
(:func:`bound`) or hold another section (:func:`nested`); :class:`Section` reads a checked
parameter set into it. A section's :meth:`Section.binding` is a :class:`Binding`
(``{argument: parameter}``), through which the errors of a core call are charged to the
parameter their argument stands for (``poles: expected 2 poles`` becomes
``observer.poles: expected 2 poles``): the error carries its argument and its reason, the
binding the parameter; no text is parsed.
"""

from contextlib import contextmanager
from dataclasses import dataclass, field, fields
from typing import Any, Iterator, Mapping

import numpy as np

from observer_ros.config.parameter_check import SOURCES_PREFIX
from observer_ros.config.schema import PARAMETER_SPECS
from observer_ros.core.errors import ConfigError, DesignError


#: Field metadata: the parameter a field is bound to, or the section a field holds.
PARAMETER, SECTION = 'parameter', 'section'

#: What numpy and scipy raise when a design's arithmetic breaks down (overflow, no
#: convergence); a design that raises one is refused like any other failed design.
NUMERIC_FAILURES = (np.linalg.LinAlgError, ValueError, ArithmeticError)


class ReadOnlyMapping(Mapping):
    """
    A read-only mapping of a copy of the one given.

    The one base of :class:`Binding` and
    :class:`~observer_ros.config.topic_sections.SettingsByName`, which differ only in what
    they add.
    """

    def __init__(self, items: Mapping[str, Any]) -> None:
        self._items = dict(items)

    def __getitem__(self, key: str) -> Any:
        return self._items[key]

    def __iter__(self) -> Iterator[str]:
        return iter(self._items)

    def __len__(self) -> int:
        return len(self._items)


class Binding(ReadOnlyMapping):
    """
    Which parameter each argument of a core call stands for: ``{argument: parameter}``.

    Made from the sections whose values a call takes (``ModelSection.binding() |
    ObserverSection.binding()``); a later section's argument of the same name wins.

    Examples
    --------
    >>> from observer_ros.config.sections import ModelSection
    >>> from observer_ros.core.errors import ConfigError
    >>> binding = ModelSection.binding()
    >>> binding['A']
    'model.A'
    >>> str(binding.error(ConfigError('B', 'expected 2x1'), 'model.A'))
    'model.B: expected 2x1'

    """

    def __or__(self, other: Mapping[str, str]) -> 'Binding':
        return Binding({**self._items, **other})

    def error(self, error: Exception, fallback: str) -> ConfigError:
        """
        Return a core error as a ConfigError naming the parameter its argument is bound to.

        An error about no bound argument (an unobservable pair names none) is charged to
        ``fallback``: the parameter whose value led to it. An error that names one of the
        bound parameters already keeps it, and so does one naming a measurement source's
        setting (``sources.<name>.outputs``, as the core's source check names it).
        """
        argument = getattr(error, 'parameter', '') or ''
        reason = getattr(error, 'reason', None) or str(error)
        if argument in self._items.values() or argument.startswith(SOURCES_PREFIX):
            return ConfigError(argument, reason)
        return ConfigError(self._items.get(argument) or fallback, reason)

    @contextmanager
    def charged(self, fallback: str, numeric: bool = False) -> Iterator[None]:
        """
        Re-raise the core's ConfigError and DesignError under their parameters.

        With ``numeric``, a numeric failure (:data:`NUMERIC_FAILURES`) of the call is
        refused too, charged to ``fallback``.
        """
        try:
            yield
        except (ConfigError, DesignError) as e:
            raise self.error(e, fallback) from e
        except NUMERIC_FAILURES as e:
            if not numeric:
                raise
            raise ConfigError(fallback, f'the design failed numerically ({e})') from e


def bound(parameter: str) -> Any:
    """
    Return a section field bound to ``parameter`` of the schema.

    Raises
    ------
    KeyError
        ``parameter`` is not in the schema (when the section is defined).

    """
    return field(metadata={PARAMETER: PARAMETER_SPECS[parameter].name})


def nested(section: type) -> Any:
    """Return a section field that holds another section (read from the same parameters)."""
    return field(metadata={SECTION: section})


@dataclass(frozen=True)
class Section:
    """
    Base of the typed sections: fields bound to parameters (:func:`bound`) or sections.

    A section whose values are not one parameter each (an observer type's arguments)
    overrides :meth:`values`, :meth:`bindings` and :meth:`parameter_names`; one that is no
    dataclass of fields (the topics, by topic) offers :meth:`read` and
    :meth:`parameter_names` itself (:class:`~observer_ros.config.topic_sections.TopicsSection`).
    """

    @classmethod
    def bindings(cls) -> dict:
        """Return ``{field name: parameter}`` of the fields bound to parameters."""
        return {item.name: item.metadata[PARAMETER] for item in fields(cls)
                if PARAMETER in item.metadata}

    @classmethod
    def binding(cls) -> Binding:
        """Return the :class:`Binding` of the section's own fields."""
        return Binding(cls.bindings())

    @classmethod
    def parameter_names(cls) -> tuple:
        """Return every parameter the section (with its nested sections) reads."""
        names = []
        for item in fields(cls):
            if PARAMETER in item.metadata:
                names.append(item.metadata[PARAMETER])
            elif SECTION in item.metadata:
                names.extend(item.metadata[SECTION].parameter_names())
        return tuple(names)

    @classmethod
    def read(cls, checked: Mapping[str, Any]) -> 'Section':
        """
        Return the section of a checked parameter mapping.

        Checked by :func:`~observer_ros.config.parameter_check.complete_parameters`.
        """
        return cls(**cls.values(checked))

    @classmethod
    def values(cls, checked: Mapping[str, Any]) -> dict:
        """Return the section's field values from a checked parameter mapping."""
        values = {}
        for item in fields(cls):
            if PARAMETER in item.metadata:
                values[item.name] = checked[item.metadata[PARAMETER]]
            elif SECTION in item.metadata:
                values[item.name] = item.metadata[SECTION].read(checked)
        return values
