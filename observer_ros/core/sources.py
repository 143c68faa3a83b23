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
Measurement sources: the model's outputs split among named sensors at their own rates.

A robot's measurements rarely come as one vector: encoders at 1 kHz, an IMU at 200 Hz, a
camera pose at 30 Hz that arrives 50 ms late. A :class:`MeasurementSource` names one of
them, the model outputs it carries (indices into ``y``) and its fixed latency; the
:class:`~observer_ros.core.events.EventEngine` takes each source's samples with their own
stamps, and the estimator updates with the outputs that arrived
(:class:`~observer_ros.core.estimators.SubsetUpdates`).

:func:`check_sources` checks a set of sources against the model (every output in exactly
one source, latencies within the history); :func:`check_subsets` asks the estimator, at
start-up, whether each source alone can be updated with, and refuses one that cannot (an
unobservable subset for a design per subset) unless it is declared ``predict_only``.
:func:`check_sources` is the one place of the rules between sources (every output in exactly
one source, a latency within the history): the parameter validation asks it instead of
checking them again, and its errors name the parameter at fault
(``sources.<name>.outputs`` is both the source's outputs here and their parameter).
"""

from dataclasses import dataclass
from typing import Optional, Sequence

from observer_ros.core.errors import ConfigError
from observer_ros.core.units import NANOSECONDS

__all__ = ['MeasurementSource', 'check_sources', 'check_subsets', 'default_source']

#: Name of the one source of a configuration without sources: every output, as today.
DEFAULT_SOURCE = 'y'


@dataclass(frozen=True)
class MeasurementSource:
    """
    One measurement source: a name, the outputs it carries and its timing.

    Attributes
    ----------
    name : str
        Unique among the sources (``odom0``, ``imu0``: the way robot_localization names
        them).
    outputs : tuple of int
        The model outputs the source's vector carries, in its order (indices into ``y``).
    latency_ns : int
        Fixed latency: each sample was taken this long before its stamp (before its
        arrival when it is stamped on arrival). The engine uses ``stamp - latency_ns`` and
        inserts the sample in stamp order through the history, which must cover it.
    timeout_ns : int
        A sample older than this (by the receiver's clock) makes the source stale in
        :meth:`~observer_ros.core.events.EventEngine.source_report` (0: never).
    predict_only : bool
        When the source's outputs alone cannot be updated with (an unobservable subset for
        an observer designed per subset), its samples alone move the estimate forward
        without a correction instead of the configuration being refused. No effect with an
        estimator that can update with them (the time-varying Kalman filter).

    Examples
    --------
    >>> imu = MeasurementSource('imu0', (2,), latency_ns=5_000_000)
    >>> imu.name, imu.outputs, imu.sorted_outputs
    ('imu0', (2,), (2,))

    """

    name: str
    outputs: tuple
    latency_ns: int = 0
    timeout_ns: int = 0
    predict_only: bool = False

    @property
    def sorted_outputs(self) -> tuple:
        """The outputs in ascending order (the order of a fused update's ``y``)."""
        return tuple(sorted(self.outputs))


def default_source(n_outputs: int) -> MeasurementSource:
    """Return the one source of a configuration without sources: every output, named ``y``."""
    return MeasurementSource(DEFAULT_SOURCE, tuple(range(n_outputs)))


def outputs_argument(name: str) -> str:
    """
    Return the name errors give the outputs of source ``name``: ``sources.<name>.outputs``.

    The same name as the source's parameter, so a configuration's error names it as it is.
    """
    return f'sources.{name}.outputs'


def _integer(name: str, what: str, value) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ConfigError('sources', f'source {name!r}: expected {what} as an integer >= 0 '
                          f'(nanoseconds), got {value!r}')
    return value


def check_sources(sources: Sequence[MeasurementSource], n_outputs: int, history_ns: int = 0,
                  output_names: Optional[Sequence[str]] = None) -> tuple:
    """
    Check a set of measurement sources against the model; return them as a tuple.

    Parameters
    ----------
    sources : sequence of MeasurementSource
    n_outputs : int
        ``p``, the model's outputs.
    history_ns : int
        The history the latencies must fit in.
    output_names : sequence of str, optional
        Names of the outputs, for the messages (``y1``... when not given).

    Returns
    -------
    tuple of MeasurementSource

    Raises
    ------
    ConfigError
        ``sources``: none given, a repeated or empty name, an output in no source, a
        negative latency or timeout; ``sources.<name>.outputs`` (the source at fault): no
        output, an output out of range, in two sources or twice in one; ``history``: a
        latency longer than the history. The one place of these rules: the parameter
        validation asks this function, which names the parameters
        (``sources.<name>.outputs`` is the parameter of the source's outputs).

    Examples
    --------
    >>> check_sources([MeasurementSource('a', (0,)), MeasurementSource('b', (0, 1))], 2)
    Traceback (most recent call last):
    ...
    observer_ros.core.errors.ConfigError: sources.b.outputs: output y1 is carried by sources 'a' \
and 'b'; each output belongs to one source (two sensors of one quantity are two outputs)

    """
    names = list(output_names) if output_names else [f'y{k + 1}' for k in range(n_outputs)]
    sources = tuple(sources)
    if not sources:
        raise ConfigError('sources', 'expected at least one measurement source, got none')
    owner: dict = {}
    seen = set()
    for source in sources:
        if not isinstance(source.name, str) or not source.name:
            raise ConfigError('sources', f'expected a non-empty name, got {source.name!r}')
        if source.name in seen:
            raise ConfigError('sources', f'source {source.name!r} is named twice')
        seen.add(source.name)
        outputs = outputs_argument(source.name)
        if not source.outputs:
            raise ConfigError(outputs, 'expected at least one output, got none')
        for index in source.outputs:
            if isinstance(index, bool) or not isinstance(index, int) or not (
                    0 <= index < n_outputs):
                raise ConfigError(outputs, f'output {index!r} is no output of the model '
                                  f'(0 ... {n_outputs - 1}: {names})')
            if owner.get(index) == source.name:
                raise ConfigError(outputs, f'output {names[index]} is named twice in source '
                                  f'{source.name!r}; each output belongs to one source, once')
            if index in owner:
                raise ConfigError(
                    outputs, f'output {names[index]} is carried by sources '
                    f'{owner[index]!r} and {source.name!r}; each output belongs to one source '
                    f'(two sensors of one quantity are two outputs)')
            owner[index] = source.name
        latency = _integer(source.name, 'latency_ns', source.latency_ns)
        _integer(source.name, 'timeout_ns', source.timeout_ns)
        if latency > history_ns:
            raise ConfigError('history', f'source {source.name!r} has a latency of '
                              f'{latency / NANOSECONDS:g} s, longer than the history '
                              f'({history_ns / NANOSECONDS:g} s) that takes its samples in '
                              f'stamp order; expected a history of at least '
                              f'{latency / NANOSECONDS:g} s')
    missing = [names[k] for k in range(n_outputs) if k not in owner]
    if missing:
        raise ConfigError('sources', f'outputs {missing} belong to no source; expected every '
                          f'output of the model in one source')
    return sources


def check_subsets(estimator, sources: Sequence[MeasurementSource],
                  output_names: Optional[Sequence[str]] = None) -> dict:
    """
    Ask the estimator whether it can update with each source alone; refuse what it cannot.

    A source whose outputs alone cannot be updated with (``estimator.subset_problem``
    says why: an unobservable subset for a design per subset, naming the unobservable
    modes) is refused, unless it is declared ``predict_only``. Several sources together
    carry more outputs, so what each can do alone they can together; a union of
    predict-only sources is asked again when it first arrives.

    Parameters
    ----------
    estimator : SubsetUpdates
        Asked through :meth:`~observer_ros.core.estimators.SubsetUpdates.subset_problem`.
    sources : sequence of MeasurementSource
    output_names : sequence of str, optional

    Returns
    -------
    dict
        ``{outputs: ()}`` for each predict-only subset found (the update to make: none).

    Raises
    ------
    ConfigError
        ``sources``: naming the source, its outputs and the reason.

    """
    n_outputs = estimator.n_outputs
    names = list(output_names) if output_names else [f'y{k + 1}' for k in range(n_outputs)]
    predict_only = {}
    for source in sources:
        outputs = source.sorted_outputs
        if len(outputs) == n_outputs:
            continue
        problem = estimator.subset_problem(outputs)
        if problem is None:
            continue
        if not source.predict_only:
            raise ConfigError(
                'sources', f'source {source.name!r} (outputs {[names[k] for k in outputs]}) '
                f'alone: {problem}; declare it predict_only (its samples alone then only '
                f'move the estimate forward), or give it more outputs')
        predict_only[outputs] = ()
    return predict_only
