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

"""Read ROS 2 parameter files (``/**: ros__parameters:``) into one flat mapping."""

from typing import Mapping, Optional

import yaml

from observer_ros.core.errors import ConfigError


def flatten_parameters(tree: Mapping, prefix: str = '') -> dict:
    """Flatten nested YAML mappings into dotted names: ``{'model': {'A': x}}`` -> ``model.A``."""
    flat = {}
    for key, value in tree.items():
        name = f'{prefix}{key}'
        if isinstance(value, Mapping):
            flat.update(flatten_parameters(value, name + '.'))
        else:
            flat[name] = value
    return flat


def load_parameter_file(path: str, node_name: Optional[str] = None) -> dict:
    """
    Read a ROS 2 parameter YAML file into a flat mapping.

    Parameters under ``/**`` apply to every node; a section named after ``node_name``
    (with or without a leading slash) is merged on top.

    Raises
    ------
    ConfigError
        Unreadable file, invalid YAML or no ``ros__parameters`` section.

    """
    try:
        with open(path, encoding='utf-8') as stream:
            document = yaml.safe_load(stream)
    except OSError as e:
        raise ConfigError('', f'cannot read parameter file {path}: {e.strerror}') from e
    except yaml.YAMLError as e:
        raise ConfigError('', f'{path} is not valid YAML: {e}') from e
    if not isinstance(document, Mapping):
        raise ConfigError('', f'{path}: expected a mapping with /**: ros__parameters:')
    flat: dict = {}
    sections = ['/**', '**']
    if node_name:
        sections += [node_name, '/' + node_name.lstrip('/')]
    found = False
    for section in sections:
        body = document.get(section)
        if isinstance(body, Mapping) and isinstance(body.get('ros__parameters'), Mapping):
            flat.update(flatten_parameters(body['ros__parameters']))
            found = True
    if not found:
        raise ConfigError('', f'{path}: no "/**: ros__parameters:" section found')
    return flat
