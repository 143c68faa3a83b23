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
The parameter schema of observer_ros, its file loader and its one validator.

ROS-free (numpy, PyYAML and the core), shared by the nodes, the design CLI and the bag tools:
:mod:`~observer_ros.config.schema` lists every parameter (the observer arguments come from
the registered observer types), :mod:`~observer_ros.config.loader` reads
``/**: ros__parameters:`` files, :func:`validate_parameters` checks a flat mapping and builds
the :class:`System`, and :mod:`~observer_ros.config.names` maps the core's argument names to
parameter names in errors.
"""

from observer_ros.config.loader import flatten_parameters, load_parameter_file
from observer_ros.config.names import ARGUMENT_PARAMETERS, named, parameter_for
from observer_ros.config.schema import (
    ALL_NODES, COVARIANCE_LIMIT, FEEDBACK, JOINT_STATE_FIELDS, MESSAGE_TYPES,
    node_parameters, OBSERVER, PARAMETER_SPECS, parameter_table, PARAMETERS, ParameterSpec,
    PLANT, ROS_PARAMETERS, TOPIC_ROLES, TOPICS, VALUE_LIMIT)
from observer_ros.config.system import (
    complete_parameters, FeedbackSettings, PlantSettings, System, validate_parameters)
from observer_ros.core.arguments import (
    BOOL, DOUBLE, DOUBLE_ARRAY, INTEGER, STRING, STRING_ARRAY)

__all__ = ['BOOL', 'DOUBLE', 'DOUBLE_ARRAY', 'INTEGER', 'STRING', 'STRING_ARRAY',
           'ALL_NODES', 'ARGUMENT_PARAMETERS', 'COVARIANCE_LIMIT', 'FEEDBACK',
           'FeedbackSettings', 'JOINT_STATE_FIELDS', 'MESSAGE_TYPES', 'OBSERVER',
           'PARAMETERS', 'PARAMETER_SPECS', 'PLANT', 'ParameterSpec', 'PlantSettings',
           'ROS_PARAMETERS', 'System', 'TOPICS', 'TOPIC_ROLES', 'VALUE_LIMIT',
           'complete_parameters', 'flatten_parameters', 'load_parameter_file', 'named',
           'node_parameters', 'parameter_for', 'parameter_table', 'validate_parameters']
