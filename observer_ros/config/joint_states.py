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
Which joints of the estimate ``joint_states_hat`` carries, and in which of its fields.

``observer.joint_names`` and the state lists ``observer.joint_position_states``,
``observer.joint_velocity_states``, ``observer.joint_effort_states``, checked once
against the model's state names into a :class:`JointStateSelection`.
"""

from dataclasses import dataclass
from typing import Optional

from observer_ros.config.sections import JointStatesSection
from observer_ros.config.values import indices
from observer_ros.core.errors import ConfigError
from observer_ros.core.model import StateSpaceModel


@dataclass(frozen=True)
class JointStateSelection:
    """
    Validated ``observer.joint_*``: which states fill each field of ``joint_states_hat``.

    Attributes
    ----------
    names : tuple of str
        The joint names.
    position, velocity, effort : tuple of int
        State indices, one per joint, or empty (the field stays empty).

    """

    names: tuple
    position: tuple = ()
    velocity: tuple = ()
    effort: tuple = ()


def joint_state_selection(section: JointStatesSection,
                          model: StateSpaceModel) -> Optional[JointStateSelection]:
    """
    Return the states of each field of ``joint_states_hat`` (None without joint names).

    Raises
    ------
    ConfigError
        Naming the ``observer.joint_*`` parameter.

    """
    binding = section.binding()
    names = tuple(section.names)
    chosen = {field: getattr(section, field) for field in ('position', 'velocity', 'effort')}
    if not names:
        for field, states in chosen.items():
            if states:
                raise ConfigError(binding[field], 'needs observer.joint_names (the joints of '
                                  'joint_states_hat)')
        return None
    if len(set(names)) != len(names):
        raise ConfigError(binding['names'], f'names must be unique, got {list(names)}')
    if not any(chosen.values()):
        raise ConfigError(binding['names'], 'expected states for at least one field: '
                          'observer.joint_position_states, observer.joint_velocity_states or '
                          'observer.joint_effort_states')
    selected = {}
    for field, states in chosen.items():
        if states and len(states) != len(names):
            raise ConfigError(binding[field], f'expected {len(names)} states (one per joint of '
                              f'observer.joint_names), got {len(states)}')
        selected[field] = indices(binding[field], states, model.state_names, 'state')
    return JointStateSelection(names, **selected)
