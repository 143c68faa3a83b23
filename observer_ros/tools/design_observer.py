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

"""``design_observer``: design from a parameter file and print the result."""

import argparse
import json
import sys
from typing import Optional

import yaml

from observer_ros.app.report import design_summary, format_report
from observer_ros.config import load_parameter_file, PARAMETER_SPECS, validate_parameters
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.signals import stops_on_signal


def designed_parameters(system) -> dict:
    """Parameters with the designed gains filled in, ready for a new parameter file."""
    params = {name: value for name, value in system.parameters.items()
              if name not in PARAMETER_SPECS or value != PARAMETER_SPECS[name].default}
    for designed in (system.observer, system.feedback):  # what pins each design as it is
        pinned = {} if designed is None else designed.pinned_parameters()
        for parameter, value in pinned.items():
            if value is None:
                params.pop(parameter, None)
            else:
                params[parameter] = value
    return params


def nest(params: dict) -> dict:
    """Turn dotted names back into nested YAML mappings."""
    tree: dict = {}
    for name, value in sorted(params.items()):
        node = tree
        parts = name.split('.')
        for part in parts[:-1]:
            node = node.setdefault(part, {})
        node[parts[-1]] = value
    return tree


def write_parameter_file(path: str, params: dict) -> None:
    """Write ``/**: ros__parameters:`` YAML (floats stay floats, as rcl requires)."""
    document = {'/**': {'ros__parameters': nest(params)}}
    with open(path, 'w', encoding='utf-8') as stream:
        stream.write('# Written by design_observer: designed gains, ready for the nodes.\n')
        yaml.safe_dump(document, stream, sort_keys=False, default_flow_style=None, width=99)


@stops_on_signal('design_observer')
def main(argv: Optional[list] = None) -> int:
    """Run the command line; returns the exit status (2 for a bad configuration)."""
    parser = argparse.ArgumentParser(
        prog='design_observer',
        description='Design the observer and state feedback of a parameter file and print '
                    'gains, poles, observer matrices, G_oc(s) and the closed-loop poles.')
    parser.add_argument('params_file', help='ROS 2 parameter YAML (/**: ros__parameters:)')
    parser.add_argument('--node', default=None,
                        help='also apply the section of this node name')
    parser.add_argument('--json', action='store_true', help='print one JSON object')
    parser.add_argument('--write', metavar='PATH',
                        help='write a parameter file with the designed gains')
    args = parser.parse_args(sys.argv[1:] if argv is None else argv)
    try:
        params = load_parameter_file(args.params_file, args.node)
        system = validate_parameters(params, strict=True)
        if args.json:
            print(json.dumps(design_summary(system)))
        else:
            print(format_report(system), end='')
        if args.write:
            write_parameter_file(args.write, designed_parameters(system))
    except (ConfigError, DesignError) as e:
        print(f'design_observer: error: {e}', file=sys.stderr)
        return 2
    return 0


if __name__ == '__main__':
    sys.exit(main())
