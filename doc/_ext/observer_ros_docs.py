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
The documentation's own Sphinx extension: the parameter reference and the reference rules.

At every build the parameter reference (``_generated/parameters.md``, included by
``parameters.md``) is written from the parameter schema's own table
(:func:`observer_ros.config.parameter_table`), so the page always says what the schema
says. Cross-references of the hand-written pages must resolve; those of the generated API
pages (``api/``), whose numpydoc type words such as ``array_like, shape (n, p)`` are no
Python objects, may stay plain text.
"""

from pathlib import Path
import re

#: The generated page, relative to the documentation's source directory.
GENERATED = Path('_generated') / 'parameters.md'

#: Columns of :func:`observer_ros.config.parameter_table` before the description.
COLUMNS = ('name', 'type', 'default', 'range', 'run_time', 'nodes')

#: Markdown's special characters, escaped in the schema's prose.
_SPECIAL = re.compile(r'([\\`*_{}\[\]<>()#+!|~$])')


def parameter_rows(table: str) -> list:
    """
    Return the rows of the schema's Markdown table as dictionaries.

    Parameters
    ----------
    table : str
        What :func:`observer_ros.config.parameter_table` returns: a header, a rule and one
        row per parameter, the description last (it may itself hold ``|``).

    Returns
    -------
    list of dict
        ``name``, ``type``, ``default`` (without the backquotes), ``range``, ``run_time``,
        ``nodes`` and ``meaning`` of each parameter, in the schema's order.

    """
    rows = []
    for line in table.strip().splitlines()[2:]:
        cells = [cell.strip() for cell in line.strip()[1:-1].split(' | ', len(COLUMNS))]
        row = dict(zip(COLUMNS, cells))
        row['name'] = row['name'].strip('`')
        row['default'] = row['default'][1:-1]
        row['meaning'] = cells[len(COLUMNS)]
        rows.append(row)
    return rows


def escape(text: str) -> str:
    """Return ``text`` with Markdown's special characters escaped, to be shown as it is."""
    return _SPECIAL.sub(r'\\\1', text)


def parameter_reference(table: str) -> str:
    """
    Return the Markdown of the parameter reference: one section per parameter group.

    Parameters
    ----------
    table : str
        The schema's table (:func:`observer_ros.config.parameter_table`).

    Returns
    -------
    str
        A section per first name component (``model``, ``observer``, ...), in the schema's
        order, with one entry per parameter: a target ``parameter-<name>`` to link to, its
        name as a heading, its type, default, range, whether it changes at run time, the
        nodes that declare it, and its description.

    """
    lines = []
    group = None
    for row in parameter_rows(table):
        head = row['name'].split('.')[0]
        if head != group:
            group = head
            lines += [f'## {head}', '']
        default = f'`{row["default"]}`' if row['default'] else '(empty)'
        facts = [f'**type** {row["type"]}', f'**default** {default}']
        if row['range']:
            facts.append(f'**range** {escape(row["range"])}')
        facts += [f'**run-time** {row["run_time"]}', f'**nodes** {escape(row["nodes"])}']
        lines += [f'(parameter-{row["name"]})=', f'### `{row["name"]}`', '',
                  ' · '.join(facts), '', escape(row['meaning']), '']
    return '\n'.join(lines)


def write_parameter_reference(app) -> None:
    """Write the parameter reference from the schema (only when it changed)."""
    from observer_ros.config import parameter_table
    path = Path(app.srcdir) / GENERATED
    text = ('<!-- Generated at every build from observer_ros.config.parameter_table(); '
            'do not edit. -->\n\n' + parameter_reference(parameter_table()))
    if not path.exists() or path.read_text(encoding='utf-8') != text:
        path.parent.mkdir(exist_ok=True)
        path.write_text(text, encoding='utf-8')


def plain_api_reference(app, env, node, contnode):
    """Leave an unresolved reference of a generated API page as plain text."""
    if node.get('refdomain') == 'py' and node.get('refdoc', '').startswith('api/'):
        return contnode
    return None


def setup(app) -> dict:
    """Register the parameter reference and the reference rule with Sphinx."""
    app.connect('builder-inited', write_parameter_reference)
    app.connect('missing-reference', plain_api_reference, priority=900)
    return {'parallel_read_safe': True, 'parallel_write_safe': True}
