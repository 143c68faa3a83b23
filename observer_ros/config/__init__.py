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
The parameter schema of observer_ros, its typed sections and its one validator.

ROS-free (numpy, PyYAML and the core), shared by the nodes, the design CLI and the bag tools:

- :mod:`~observer_ros.config.schema` lists every parameter (the observer arguments come
  from the registered observer types) and :mod:`~observer_ros.config.loader` reads
  ``/**: ros__parameters:`` files;
- :mod:`~observer_ros.config.sections` checks a parameter set once and reads it into typed
  sections, each field bound to its parameter (:class:`Sections`);
- :func:`validate_parameters` (:mod:`~observer_ros.config.configuration`) makes the
  :class:`Configuration` of a parameter set: the model and its disturbance transform
  (:class:`Augmentation`), the observer (:class:`ObserverSetup`, which makes the estimator
  and the event stream), the state feedback (:class:`FeedbackSettings`), the simulated plant
  (:class:`PlantSettings`) and the loop analysis (:class:`LoopAnalysis`).
"""

from observer_ros.config.binding import Binding
from observer_ros.config.configuration import (
    Configuration, NODE_PARTS, PARTS, validate_parameters)
from observer_ros.config.feedback import FeedbackSettings
from observer_ros.config.joint_states import JointStateSelection
from observer_ros.config.loader import (
    check_parameter_lists, flatten_parameters, load_parameter_file, read_parameter_document)
from observer_ros.config.loop import LoopAnalysis
from observer_ros.config.model import Augmentation
from observer_ros.config.observer import ObserverSetup
from observer_ros.config.parameter_check import complete_parameters
from observer_ros.config.plant import PlantSettings
from observer_ros.config.schema import (
    ALL_NODES, COMBINED_NODES, CONTROLLER, CONTROLLER_INPUTS, COVARIANCE_LIMIT, FEEDBACK,
    JOINT_STATE_FIELDS, MESSAGE_TYPES, node_parameters, OBSERVER, OBSERVER_ARGUMENTS,
    PARAMETER_SPECS, parameter_table,
    PARAMETERS, ParameterSpec, PLANT, ROS_PARAMETERS, TOPIC_ROLES, TOPICS, VALUE_LIMIT)
from observer_ros.config.sections import Sections
from observer_ros.config.topic_sections import TopicSettings
from observer_ros.core.arguments import (
    BOOL, DOUBLE, DOUBLE_ARRAY, INTEGER, STRING, STRING_ARRAY)

__all__ = ['BOOL', 'DOUBLE', 'DOUBLE_ARRAY', 'INTEGER', 'STRING', 'STRING_ARRAY',
           'ALL_NODES', 'Augmentation', 'Binding', 'COMBINED_NODES', 'CONTROLLER',
           'CONTROLLER_INPUTS', 'COVARIANCE_LIMIT', 'Configuration',
           'FEEDBACK', 'FeedbackSettings', 'JOINT_STATE_FIELDS', 'JointStateSelection',
           'LoopAnalysis', 'MESSAGE_TYPES', 'NODE_PARTS', 'OBSERVER', 'OBSERVER_ARGUMENTS',
           'ObserverSetup', 'PARAMETERS', 'PARAMETER_SPECS', 'PARTS', 'PLANT',
           'ParameterSpec', 'PlantSettings', 'ROS_PARAMETERS', 'Sections', 'TOPICS',
           'TOPIC_ROLES', 'TopicSettings', 'VALUE_LIMIT', 'check_parameter_lists',
           'complete_parameters', 'flatten_parameters', 'load_parameter_file',
           'node_parameters', 'parameter_table', 'read_parameter_document',
           'validate_parameters']
