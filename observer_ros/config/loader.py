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


def _kind(value) -> str:
    """Return the kind of a list element as the ROS YAML loader types it."""
    if isinstance(value, bool):
        return 'bool'
    if isinstance(value, int):
        return 'integer'
    if isinstance(value, float):
        return 'float'
    return 'string' if isinstance(value, str) else type(value).__name__


def check_parameter_lists(flat: Mapping) -> None:
    """
    Refuse a list of mixed types, as the ROS YAML loader (rcl) does for a params file.

    Raises
    ------
    ConfigError
        Naming the parameter: ``[0.05, 0, 1]`` mixes floats and integers, which rcl refuses
        (so the nodes cannot start on the file); every value must then be written as a float.

    """
    for name, value in flat.items():
        if not isinstance(value, list):
            continue
        kinds = sorted({_kind(element) for element in value})
        if len(kinds) < 2:
            continue
        if kinds == ['float', 'integer']:
            whole = next(element for element in value if _kind(element) == 'integer')
            raise ConfigError(name, f'a list mixing integers and floats ({value}): the ROS '
                              f'parameter loader refuses it; write every value as a float '
                              f'({whole}.0, not {whole})')
        raise ConfigError(name, f'a list mixing {" and ".join(kinds)} values ({value}): the '
                          f'ROS parameter loader refuses it; expected values of one type')


def read_parameter_document(path: str) -> Mapping:
    """
    Read a ROS 2 parameter YAML file as the nodes' loader would, every section checked.

    Raises
    ------
    ConfigError
        Unreadable file, invalid YAML, not a mapping, or a list of mixed types in any
        ``ros__parameters`` section (see :func:`check_parameter_lists`).

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
    for body in document.values():
        if isinstance(body, Mapping) and isinstance(body.get('ros__parameters'), Mapping):
            try:
                check_parameter_lists(flatten_parameters(body['ros__parameters']))
            except ConfigError as e:
                raise ConfigError(e.parameter, f'{e.reason} (in {path})') from None
    return document


def load_parameter_file(path: str, node_name: Optional[str] = None) -> dict:
    """
    Read a ROS 2 parameter YAML file into a flat mapping.

    Parameters under ``/**`` apply to every node; a section named after ``node_name``
    (with or without a leading slash) is merged on top.

    Raises
    ------
    ConfigError
        Unreadable file, invalid YAML, no ``ros__parameters`` section, or a list of mixed
        types that the nodes' loader refuses (:func:`check_parameter_lists`).

    """
    document = read_parameter_document(path)
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
