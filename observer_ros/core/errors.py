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
Exceptions raised by the observer_ros core.

Every error the core raises on purpose names the argument it is about, in the words of the
function that raised it, the way scipy's ``place_poles`` says "A must be square"::

    gain: expected 2x1 (2 values, row-major), got 3

Names follow one convention:

- the state-space matrices are ``A``, ``B``, ``C`` and ``D`` (upper case, as scipy and
  python-control write them), whether a function takes them as separate arguments
  (``place(a, b, poles)``) or inside a :class:`~observer_ros.core.model.StateSpaceModel`;
  the model's sample period is ``dt``, its names ``state_names``, ``input_names`` and
  ``output_names``;
- ``model`` when a whole model does not suit the function (a discrete model given to a
  function that samples a continuous one, a plant with several inputs given to a SISO
  function);
- every other argument by its own name: ``poles``, ``gain``, ``method``, ``process_noise``,
  ``measurement_noise``, ``initial_state``, ``input_limits``...

:class:`ConfigError` and :class:`DesignError` carry the name in ``parameter`` and the message
without it in ``reason``, so a boundary (the ROS nodes, the design CLI, the bag tools) maps
``(function, parameter)`` to its own parameter name and re-raises with ``reason``, without
editing the text.
"""


def _text(parameter: str, reason: str) -> str:
    return f'{parameter}: {reason}' if parameter else reason


class ObserverRosError(Exception):
    """
    Base class of every error the core raises on purpose.

    Examples
    --------
    >>> from observer_ros.core import ConfigError, ObserverRosError
    >>> issubclass(ConfigError, ObserverRosError)
    True

    """


class ConfigError(ObserverRosError, ValueError):
    """
    An argument has a wrong shape, type or value.

    Parameters
    ----------
    parameter : str
        Name of the offending argument, for example ``'gain'`` or ``'B'`` (see the module
        notes for the convention); empty when the error is about no single argument.
    reason : str
        What was expected and what was given, without the name.

    Attributes
    ----------
    parameter : str
    reason : str
        As given; ``str(error)`` is ``'parameter: reason'`` (``reason`` alone when
        ``parameter`` is empty).

    Examples
    --------
    >>> from observer_ros.core import ConfigError
    >>> error = ConfigError('gain', 'expected 2x1 (2 values, row-major), got 3')
    >>> str(error)
    'gain: expected 2x1 (2 values, row-major), got 3'
    >>> error.parameter, error.reason
    ('gain', 'expected 2x1 (2 values, row-major), got 3')

    A boundary renames the argument without touching the text:

    >>> str(ConfigError('observer.gain', error.reason))
    'observer.gain: expected 2x1 (2 values, row-major), got 3'

    """

    def __init__(self, parameter: str, reason: str) -> None:
        self.parameter = parameter
        self.reason = reason
        super().__init__(_text(parameter, reason))

    def __reduce__(self):
        """Pickle with both fields (the default would pass only the joined message)."""
        return type(self), (self.parameter, self.reason)


class DesignError(ObserverRosError, ValueError):
    """
    A design cannot produce a correct gain (unobservable pair, placement failure...).

    Parameters
    ----------
    reason : str
        What went wrong, without the argument's name.
    parameter : str, optional
        The argument the failure is about (``'poles'`` for requested poles that are not
        stable, ``'gain'`` for a given gain that does not stabilize); empty (the default)
        when it is about the problem as a whole, such as an unobservable pair.

    Attributes
    ----------
    parameter : str
    reason : str
        As given; ``str(error)`` is ``'parameter: reason'`` (``reason`` alone when
        ``parameter`` is empty).

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> model = oc.StateSpaceModel.from_matrices([[0, 1], [0, 0]], [[0], [1]], [[1, 0]])
    >>> try:
    ...     oc.design_full_order(model, poles=[1, -2])
    ... except oc.DesignError as e:
    ...     print(e.parameter)
    ...     print(e.reason.split(';')[0])
    poles
    requested poles 1, -2 are not stable

    """

    def __init__(self, reason: str = '', parameter: str = '') -> None:
        self.parameter = parameter
        self.reason = reason
        super().__init__(_text(parameter, reason))

    def __reduce__(self):
        """Pickle with both fields."""
        return type(self), (self.reason, self.parameter)


class UnobservableError(DesignError):
    """
    A mode that no output sees (that does not decay, for a Kalman filter) refuses a design.

    Raised by :func:`observer_ros.core.analysis.require_observable`, the one observability
    rule; a :class:`DesignError` without a ``parameter``, so that the configuration layer may
    add which measurement sources carry the outputs.

    Examples
    --------
    >>> import observer_ros.core as oc
    >>> isinstance(oc.UnobservableError('(A, C) is not observable'), oc.DesignError)
    True

    """


class StampError(ObserverRosError, ValueError):
    """
    A sample's time stamp is not usable (not after the previous one).

    Examples
    --------
    >>> from observer_ros.core import StampError
    >>> isinstance(StampError('stamp_ns: not after the previous sample'), ValueError)
    True

    """
