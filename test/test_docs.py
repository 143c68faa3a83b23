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
The documentation site builds, says what the code says, and its links resolve offline.

The site (``doc/``) is built once per test run with warnings as errors, as
``scripts/docs.sh`` builds it (Sphinx's own checks then cover the toctree, the
cross-references and the MyST links and anchors); the built HTML is then checked again:
the parameter page against the schema, every internal link and anchor. External links are
listed here, never fetched.
"""

import fcntl
import html
import json
import os
from pathlib import Path
import re
import subprocess
import sys
import time
from urllib.parse import unquote, urlsplit

import pytest

from conftest import console_scripts, REPOSITORY
from doc_support import heading_slugs, links, pages
from observer_ros.config import parameter_table, PARAMETERS
from observer_ros.config.schema import SOURCE_NAME, source_specs

DOC = REPOSITORY / 'doc'
sys.path.insert(0, str(DOC / '_ext'))
from observer_ros_docs import parameter_reference, parameter_rows  # noqa: E402, I100, I202

#: The external links the pages may have (checked for being listed, not fetched).
EXTERNAL_LINKS = ()


@pytest.fixture(scope='session')
def site(tmp_path_factory) -> Path:
    """
    Build the site once per test run; return the directory of the build.

    Under pytest-xdist the workers share one build (a lock and the run's id); the build's
    exit status, output and duration are kept in ``result.json`` beside the HTML.
    """
    for module in ('sphinx', 'myst_parser'):
        # requirements.txt has them; a ROS 2 install without them skips the build.
        pytest.importorskip(module)
    run = os.environ.get('PYTEST_XDIST_TESTRUNUID')
    base = tmp_path_factory.getbasetemp()
    root = base.parent if run else base
    output = root / f'doc-site-{run or "local"}'
    with open(root / f'doc-site-{run or "local"}.lock', 'w', encoding='utf-8') as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        result_file = output / 'result.json'
        if not result_file.exists():
            output.mkdir(exist_ok=True)
            start = time.monotonic()
            result = subprocess.run(
                [sys.executable, '-m', 'sphinx', '-W', '--keep-going', '-b', 'html',
                 '-d', str(output / 'doctrees'), str(DOC), str(output / 'html')],
                capture_output=True, text=True, timeout=600)
            result_file.write_text(json.dumps({
                'returncode': result.returncode, 'stdout': result.stdout[-5000:],
                'stderr': result.stderr[-20000:],
                'seconds': time.monotonic() - start}), encoding='utf-8')
    return output


def built(site: Path) -> dict:
    return json.loads((site / 'result.json').read_text(encoding='utf-8'))


def text_of(page: Path) -> str:
    """Return the visible text of an HTML page, whitespace collapsed."""
    body = re.sub(r'<(script|style)\b.*?</\1>', ' ', page.read_text(encoding='utf-8'),
                  flags=re.S)
    return re.sub(r'\s+', ' ', html.unescape(re.sub(r'<[^>]+>', ' ', body)))


def test_the_docs_build_with_warnings_as_errors(site):
    result = built(site)
    assert result['returncode'] == 0, (
        f'sphinx-build -W failed:\n{result["stderr"]}\n{result["stdout"]}')
    print(f'documentation built in {result["seconds"]:.1f} s')
    for page in pages()[1:]:
        name = page.relative_to(DOC).with_suffix('.html')
        assert (site / 'html' / name).is_file(), f'{name} was not built'


def test_the_parameter_page_equals_the_schema(site):
    assert built(site)['returncode'] == 0
    page = site / 'html' / 'parameters.html'
    source = page.read_text(encoding='utf-8')
    text = text_of(page)
    rows = parameter_rows(parameter_table())
    # Every schema parameter, then the settings of a measurement source (sources.<name>.*).
    assert [row['name'] for row in rows] == [spec.name for spec in PARAMETERS
                                             + source_specs(SOURCE_NAME)]
    position = 0
    for row in rows:
        anchor = 'parameter-' + re.sub(r'[^a-z0-9]+', '-', row['name'].lower())
        assert f'id="{anchor}"' in source, f'no entry for {row["name"]}'
        entry = f'{row["name"]} ¶ type {row["type"]} · default'
        found = text.find(entry, position)
        assert found >= 0, f'{row["name"]}: not where the schema puts it'
        meaning = re.sub(r'\s+', ' ', row['meaning'])
        position = text.find(meaning, found)
        assert position >= 0, f'{row["name"]}: the description differs from the schema'
        assert f'run-time {row["run_time"]}' in text[found:position]
    assert source.count('id="parameter-') == len(rows)


def _internal_targets(page: Path) -> list:
    source = page.read_text(encoding='utf-8')
    for href in re.findall(r'href="([^"]+)"', source):
        parts = urlsplit(html.unescape(href))
        if parts.scheme or parts.netloc:
            continue
        yield href, parts


def test_every_internal_link_and_anchor_of_the_site_resolves(site):
    assert built(site)['returncode'] == 0
    root = site / 'html'
    ids = {}
    broken = []
    for page in sorted(root.rglob('*.html')):
        for href, parts in _internal_targets(page):
            target = (page.parent / unquote(parts.path)).resolve() if parts.path else page
            if not target.exists():
                broken.append(f'{page.relative_to(root)}: {href}')
                continue
            if parts.fragment and target.suffix == '.html':
                if target not in ids:
                    ids[target] = set(re.findall(r'\bid="([^"]+)"',
                                                 target.read_text(encoding='utf-8')))
                if unquote(parts.fragment) not in ids[target]:
                    broken.append(f'{page.relative_to(root)}: {href}')
    assert not broken, 'broken links:\n' + '\n'.join(broken)


def test_every_markdown_link_of_the_pages_resolves():
    broken = []
    for page in pages():
        for target in links(page):
            parts = urlsplit(target)
            if parts.scheme or parts.netloc:
                continue
            path = (page.parent / unquote(parts.path)).resolve() if parts.path else page
            if not path.exists():
                broken.append(f'{page.relative_to(REPOSITORY)}: {target}')
            elif parts.fragment and path.suffix == '.md':
                generated = {'parameters.md': parameter_reference(parameter_table())}
                if parts.fragment not in heading_slugs(path, generated):
                    broken.append(f'{page.relative_to(REPOSITORY)}: {target} (no such heading)')
    assert not broken, 'broken links:\n' + '\n'.join(broken)


def test_external_links_are_listed_not_fetched():
    external = sorted({target for page in pages() for target in links(page)
                       if urlsplit(target).scheme})
    unlisted = [target for target in external if target not in EXTERNAL_LINKS]
    assert not unlisted, f'external links not in EXTERNAL_LINKS: {unlisted}'
    assert all(target.startswith('https://') for target in EXTERNAL_LINKS)


def test_every_executable_has_its_page():
    index = (DOC / 'nodes' / 'index.md').read_text(encoding='utf-8')
    readme = (REPOSITORY / 'README.md').read_text(encoding='utf-8')
    for name in console_scripts():
        page = DOC / 'nodes' / f'{name}.md'
        assert page.is_file(), f'no page for {name}'
        assert page.read_text(encoding='utf-8').startswith(f'# {name}\n'), page
        assert f'[`{name}`]({name}.md)' in index, name
        assert f'`{name}`' in readme, name


def test_every_shipped_config_is_documented():
    examples = (DOC / 'concepts.md').read_text(encoding='utf-8')
    for path in sorted((REPOSITORY / 'config').glob('*.*')):
        assert f'`{path.name}`' in examples, path.name


def test_every_test_the_docs_cite_exists():
    defined = set()
    for path in (REPOSITORY / 'test').glob('test_*.py'):
        defined.update(re.findall(r'^def (test_\w+)', path.read_text(encoding='utf-8'), re.M))
    cited = set()
    for page in pages():
        cited.update(re.findall(r'`(test_\w+)`', page.read_text(encoding='utf-8')))
    assert cited and cited <= defined, sorted(cited - defined)


@pytest.mark.parametrize('name', console_scripts())
def test_every_option_of_an_executable_is_on_its_page(name, capsys):
    # closed_loop's page used to leave --controller out.
    from importlib.metadata import entry_points
    (entry,) = [point for point in entry_points(group='console_scripts')
                if point.name == name and point.value.startswith('observer_ros.')]
    with pytest.raises(SystemExit) as raised:
        entry.load()([name, '--help'])
    assert raised.value.code == 0
    options = set(re.findall(r'(?<![\w-])(--[a-z][\w-]*\w)', capsys.readouterr().out))
    options -= {'--help', '--ros-args', '--ros'}
    # The executable's page, and the one of what every node shares (--executor).
    page = ''.join((DOC / 'nodes' / f'{page}.md').read_text(encoding='utf-8')
                   for page in (name, 'index'))
    assert options and not [option for option in sorted(options)
                            if f'`{option}' not in page], name
