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
The sample rate of a configuration, and the time-like parameters checked against it.

:func:`plant_rate` is the rate the plant simulator runs at, :func:`sample_rate` the rate
the nodes expect their inputs at (``diagnostics.expected_rate``, else the plant's), and
:func:`check_sample_period` refuses a time-like parameter that cannot work at one sample
period (:data:`PERIOD_RULES`).
"""

from typing import Collection

from observer_ros.config.sections import Sections
from observer_ros.core.arguments import number_text
from observer_ros.core.errors import ConfigError
from observer_ros.core.model import StateSpaceModel

#: The plant rate of a continuous model when ``plant.rate_hz`` is 0 (follow the model).
DEFAULT_RATE_HZ = 100.0


def plant_rate(sections: Sections, model: StateSpaceModel) -> float:
    """
    Return the plant rate: ``plant.rate_hz``, or with 0 the model's own.

    Raises
    ------
    ConfigError
        ``plant.rate_hz`` between 0 and 0.01 Hz, or not ``1 / model.dt`` for a discrete
        model.

    """
    rate = sections.plant.rate_hz
    if rate == 0.0:
        return 1.0 / model.dt if model.is_discrete else DEFAULT_RATE_HZ
    if rate < 0.01:
        raise ConfigError('plant.rate_hz', f'expected 0 (the model rate) or a rate in '
                          f'[0.01, 10000] Hz, got {number_text(rate)}')
    if model.is_discrete and abs(rate * model.dt - 1.0) > 1e-9:
        raise ConfigError('plant.rate_hz', f'a discrete model with model.dt = {model.dt} s '
                          f'runs at {1.0 / model.dt:g} Hz, got {rate}')
    return rate


def sample_rate(sections: Sections, model: StateSpaceModel, plant: bool = False) -> tuple:
    """
    Return ``(rate_hz, source)``: the rate the samples come at, and the parameter that sets it.

    ``diagnostics.expected_rate``, else (and with ``plant`` always) the plant rate
    (:func:`plant_rate`: ``plant.rate_hz``, ``1 / model.dt``, or 100 Hz for a continuous
    model). The nodes watch their inputs against it and the time-like parameters are
    checked against its period (:data:`PERIOD_RULES`).
    """
    expected = sections.diagnostics.expected_rate
    if expected > 0 and not plant:
        return expected, 'diagnostics.expected_rate'
    rate = plant_rate(sections, model)
    if sections.plant.rate_hz:
        return rate, 'plant.rate_hz'
    if model.is_discrete:
        return rate, 'model.dt'
    return rate, (f'the {number_text(DEFAULT_RATE_HZ)} Hz assumed for a continuous model; set '
                  + ('plant.rate_hz' if plant else 'diagnostics.expected_rate'))


#: Time-like parameters checked against one sample period: ``(section, field, whether it
#: follows the plant's rate (else the sample rate), what 0 means (None: not allowed),
#: whether it must be below the period (else above), what would go wrong)``.
PERIOD_RULES = (
    ('plant', 'command_timeout', True, None, False, 'every sample would find the command '
     'stale'),
    ('feedback', 'timeout', False, None, False, 'the safe command would replace the commands '
     'computed from most estimates'),
    ('observer', 'max_gap', False, None, False, 'every sample interval would restart the '
     'estimator'),
    ('observer', 'interval_resolution', False, 'exact intervals', True, 'a sample interval '
     'would be designed as a whole multiple of it, half a sample period or more off the '
     'real one'),
    ('diagnostics', 'stale_timeout', False, 'automatic', False, 'every input would be stale '
     'between two samples'),
)


def check_sample_period(sections: Sections, model: StateSpaceModel,
                        given: Collection[str]) -> None:
    """
    Refuse a time-like parameter that cannot work at the sample period (:data:`PERIOD_RULES`).

    Only the parameters in ``given`` are checked: a node gives every parameter it declares,
    so each node checks its own (not the defaults of another node's), a file what it sets.

    Raises
    ------
    ConfigError
        Naming the parameter, the period and where the period comes from.

    """
    for section_name, argument, plant, zero, below, harm in PERIOD_RULES:
        section = getattr(sections, section_name)
        name = section.binding()[argument]
        value = getattr(section, argument)
        if name not in given or (zero is not None and value == 0.0):
            continue
        rate, source = sample_rate(sections, model, plant)
        if (value * rate >= 1.0) if below else (value * rate <= 1.0):
            expected = (f'0 ({zero}) or ' if zero else '') + (
                'seconds below' if below else 'more than') + ' one sample period'
            raise ConfigError(name, f'expected {expected} ({number_text(1.0 / rate)} s at '
                              f'{number_text(rate)} Hz, from {source}), got '
                              f'{number_text(value)}: {harm}')
