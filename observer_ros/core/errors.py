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

"""Exceptions raised by the observer_ros core."""


class ObserverRosError(Exception):
    """Base class of every error the core raises on purpose."""


class ConfigError(ObserverRosError, ValueError):
    """
    A parameter has a wrong shape, type or value.

    Parameters
    ----------
    parameter : str
        Name of the offending parameter, for example ``'model.B'``.
    message : str
        What was expected and what was given.

    """

    def __init__(self, parameter: str, message: str) -> None:
        self.parameter = parameter
        self.reason = message
        super().__init__(f'{parameter}: {message}' if parameter else message)


class DesignError(ObserverRosError, ValueError):
    """A design cannot produce a correct gain (unobservable pair, placement failure...)."""


class StampError(ObserverRosError, ValueError):
    """A sample's time stamp is not usable (not after the previous one)."""
