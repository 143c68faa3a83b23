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
The one table from the core's argument names to the parameter names, and its use.

Core functions name their own arguments in their errors (``gain: expected 2x1``); the
validator re-raises such an error under the parameter it came from
(``observer.gain: expected 2x1``) with :func:`named`, for the nodes, the CLI and the bag tools
alike. Nothing parses the messages: the error carries its argument and its reason.
"""

from typing import Optional

from observer_ros.config.schema import PARAMETER_SPECS
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.observers import observer_arguments

_MODEL = {'A': 'model.A', 'a': 'model.A', 'B': 'model.B', 'b': 'model.B', 'C': 'model.C',
          'c': 'model.C', 'D': 'model.D', 'd': 'model.D', 'dt': 'model.dt',
          'state_names': 'model.state_names', 'input_names': 'model.input_names',
          'output_names': 'model.output_names',
          **{name: f'model.{name}' for name in (
              'disturbances', 'disturbance_entries', 'disturbance_matrix',
              'disturbance_frequencies', 'disturbance_names')}}

#: Context -> argument -> parameter. A context is the part of the schema a core call serves.
ARGUMENT_PARAMETERS = {
    'model': dict(_MODEL),
    'observer': {**_MODEL, 'type': 'observer.type', 'initial_state': 'observer.initial_state',
                 'interval_resolution_ns': 'observer.interval_resolution',
                 **{argument.name: f'observer.{argument.name}'
                    for argument in observer_arguments()}},
    'feedback': {**_MODEL, 'gain': 'feedback.gain', 'poles': 'feedback.poles',
                 'method': 'feedback.method', 'reference_gain': 'feedback.reference_gain',
                 'input_limits': 'feedback.input_limits',
                 'safe_command': 'feedback.safe_command', 'timeout': 'feedback.timeout'},
    'integral': {**_MODEL, 'gain': 'feedback.gain', 'poles': 'feedback.integral_poles',
                 'integral_gain': 'feedback.integral_gain',
                 'outputs': 'feedback.integral_outputs', 'method': 'feedback.method'},
    'plant': {**_MODEL, 'initial_state': 'plant.initial_state',
              'process_noise': 'plant.process_noise',
              'measurement_noise': 'plant.measurement_noise',
              'input_limits': 'plant.input_limits', 'seed': 'plant.seed',
              'safe_input': 'plant.safe_input'},
}


def parameter_for(context: str, argument: Optional[str]) -> Optional[str]:
    """Return the parameter an argument of ``context`` stands for (None when unknown)."""
    if not argument:
        return None
    if argument in PARAMETER_SPECS:
        return argument
    return ARGUMENT_PARAMETERS[context].get(argument)


def named(error: Exception, context: str, fallback: str) -> ConfigError:
    """
    Return ``error`` as a ConfigError naming the parameter it is about.

    The error's own argument (``error.parameter``) is looked up in the table of ``context``;
    an error about no known argument is charged to ``fallback`` (the parameter whose value
    led to it: ``observer.poles`` for a failed pole placement, for instance).
    """
    argument = getattr(error, 'parameter', None)
    reason = getattr(error, 'reason', None)
    parameter = parameter_for(context, argument)
    if parameter is not None and reason is not None:
        return ConfigError(parameter, reason)
    if isinstance(error, (ConfigError, DesignError)) and argument:
        return ConfigError(parameter or fallback, reason or str(error))
    text = str(error)
    if isinstance(error, DesignError) and text.split(': ', 1)[0] in PARAMETER_SPECS:
        return ConfigError('', text)  # a design message that names its parameter itself
    return ConfigError(fallback, text)
