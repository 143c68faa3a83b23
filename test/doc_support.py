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
The documentation's pages read as a user reads them: code blocks, commands and links.

The pages are README.md and the Markdown pages of ``doc/`` (the generated parameter
reference excepted). :func:`code_blocks` finds their fenced blocks, :func:`commands` splits a
shell block into the commands a user types (continuation lines and here-documents joined),
and :func:`links` lists their Markdown links. Run as a script, this module is the node
runner of ``test_doc_commands.py``: it starts a node executable, lets it come up, stops it
with SIGINT and exits with the node's exit status.
"""

from dataclasses import dataclass
import os
from pathlib import Path
import re
import signal
import subprocess
import sys
import threading
import time

REPOSITORY = Path(__file__).resolve().parents[1]
DOC = REPOSITORY / 'doc'

#: First line of a shell block whose commands need a ROS 2 install (``ros2``, ``colcon``).
ROS_INSTALL_MARK = '# On a ROS 2 Jazzy install'

#: The line before a ```text block that shows what the shell block before it prints.
OUTPUT_MARK = '<!-- output of the commands above -->'

#: Languages of the fenced blocks that hold shell commands.
SHELL_LANGUAGES = ('bash', 'sh', 'shell')

#: Seconds a node may take to come up (say something, or open its DDS sockets) at most.
NODE_START_SECONDS = 60.0

#: Seconds a node runs after its first line before it is stopped.
NODE_RUN_SECONDS = 1.0

_FENCE = re.compile(r'^(?P<indent> {0,3})(?P<fence>`{3,}|~{3,})(?P<info>[^`]*)$')
_HEREDOC = re.compile(r"<<-?\s*'?\"?(?P<word>\w+)'?\"?")
_LINK = re.compile(r'(?<!!)\[(?P<text>[^\]]*)\]\((?P<target>[^)\s]+)\)')


def pages() -> list:
    """Return README.md and every hand-written Markdown page of ``doc/``."""
    found = [REPOSITORY / 'README.md']
    for path in sorted(DOC.rglob('*.md')):
        parts = path.relative_to(DOC).parts
        if not any(part.startswith('_') for part in parts):
            found.append(path)
    return found


@dataclass(frozen=True)
class CodeBlock:
    """A fenced code block of a page: its language, first line number and text."""

    path: Path
    language: str
    line: int
    text: str
    #: The nearest non-blank line before the opening fence.
    preceded_by: str = ''

    @property
    def where(self) -> str:
        """``page:line`` of the block, for messages."""
        return f'{self.path.relative_to(REPOSITORY)}:{self.line}'

    @property
    def needs_ros_install(self) -> bool:
        """Whether the block is marked as commands for a ROS 2 install."""
        return self.text.startswith(ROS_INSTALL_MARK)


def code_blocks(path: Path) -> list:
    """Return the fenced code blocks of a Markdown page, directives (```{name}) excepted."""
    blocks = []
    lines = path.read_text(encoding='utf-8').splitlines()
    index = 0
    while index < len(lines):
        match = _FENCE.match(lines[index])
        if not match:
            index += 1
            continue
        fence, info = match['fence'], match['info'].strip()
        start = index + 1
        index = start
        while index < len(lines) and not lines[index].strip().startswith(fence):
            index += 1
        if not info.startswith('{'):
            language = info.split()[0] if info else ''
            before = next((line.strip() for line in reversed(lines[:start - 1])
                           if line.strip()), '')
            blocks.append(CodeBlock(path, language, start + 1,
                                    '\n'.join(lines[start:index]) + '\n', before))
        index += 1
    return blocks


@dataclass(frozen=True)
class Command:
    """One command of a shell block as a user types it (continuations joined)."""

    text: str
    line: int

    @property
    def words(self) -> list:
        """The command's words, roughly (no quoting rules): enough to classify it."""
        first = self.text.split('\n')[0]
        return first.replace('\\', ' ').split()

    @property
    def background(self) -> bool:
        """Whether the command ends with ``&``."""
        return self.text.rstrip().endswith('&') and not self.text.rstrip().endswith('&&')


def commands(block: CodeBlock) -> list:
    """
    Split a shell block into its commands.

    Comment lines and blank lines are left out, lines ending with a backslash are joined
    with the next, and a here-document (``cat > f <<'YAML'`` ... ``YAML``) stays with its
    command. A comment after a command is removed with it (``design_observer f  # the
    report``).
    """
    result = []
    lines = block.text.splitlines()
    index = 0
    while index < len(lines):
        line = lines[index]
        number = block.line + index
        index += 1
        if not line.strip() or line.lstrip().startswith('#'):
            continue
        parts = [line]
        while parts[-1].endswith('\\') and index < len(lines):
            parts.append(lines[index])
            index += 1
        heredoc = _HEREDOC.search(parts[0])
        if heredoc:
            while index < len(lines):
                parts.append(lines[index])
                index += 1
                if parts[-1].strip() == heredoc['word']:
                    break
        else:
            parts[-1] = re.sub(r'\s+#\s.*$', '', parts[-1])
        result.append(Command('\n'.join(parts), number))
    return result


def _same(expected: str, got: str) -> bool:
    """Whether two output lines agree: the same words, numbers within 5 % (or 1e-9)."""
    want, have = expected.split(), got.split()
    if len(want) != len(have):
        return False
    for one, other in zip(want, have):
        try:
            a, b = float(one), float(other)
        except ValueError:
            if one != other:
                return False
            continue
        if abs(a - b) > max(0.05 * max(abs(a), abs(b)), 1e-9):
            return False
    return True


def shows(expected: str, output: str) -> bool:
    """
    Whether ``output`` holds the lines of ``expected`` in order.

    A line ``...`` of ``expected`` stands for any number of lines; the lines between two of
    them must follow each other in ``output``. Numbers agree within 5 % (or 1e-9), so that
    the shown output survives another BLAS, and words exactly.
    """
    lines = [line for line in output.splitlines() if line.strip()]
    position = 0
    chunk = []
    for part in expected.splitlines() + ['...']:
        if part.strip() != '...':
            if part.strip():
                chunk.append(part)
            continue
        if chunk:
            for start in range(position, len(lines) - len(chunk) + 1):
                if all(_same(want, have) for want, have in zip(chunk,
                                                               lines[start:start + len(chunk)])):
                    position = start + len(chunk)
                    break
            else:
                return False
        chunk = []
    return True


def links(path: Path) -> list:
    """Return the targets of the Markdown links of a page (images excepted), in order."""
    text = path.read_text(encoding='utf-8')
    text = re.sub(r'^(`{3,}|~{3,}).*?^\1', '', text, flags=re.M | re.S)
    text = re.sub(r'`[^`\n]*`', '', text)
    return [match['target'] for match in _LINK.finditer(text)]


def heading_slugs(path: Path, generated: dict = None) -> set:
    """
    Return the anchors of a page's headings as GitHub and MyST write them.

    The headings of a file the page includes (```{include} file```) count as the page's;
    ``generated`` gives the text of an included file the build writes, by its name.
    """
    text = path.read_text(encoding='utf-8')
    for name in re.findall(r'^```\{include\}\s+(\S+)', text, flags=re.M):
        included = path.parent / name
        if included.exists():
            text += '\n' + included.read_text(encoding='utf-8')
        else:
            text += '\n' + (generated or {}).get(included.name, '')
    text = re.sub(r'^(`{3,}|~{3,}).*?^\1', '', text, flags=re.M | re.S)
    slugs = set()
    for heading in re.findall(r'^#{1,6}\s+(.+?)\s*$', text, flags=re.M):
        slug = re.sub(r'[^\w\- ]', '', heading.strip().lower()).replace(' ', '-')
        slugs.add(slug)
    return slugs


def has_sockets(pid: int) -> bool:
    """Whether a process has opened a socket: its DDS participant exists, its imports are done."""
    try:
        return any(os.readlink(f'/proc/{pid}/fd/{fd}').startswith('socket:')
                   for fd in os.listdir(f'/proc/{pid}/fd'))
    except OSError:
        return False


def run_node(argv: list, background: bool = False) -> int:
    """
    Start a node executable, let it come up, stop it with SIGINT; return its exit status.

    In the foreground the node is stopped :data:`NODE_RUN_SECONDS` after it has come up:
    after its first line of output or, for a node that says nothing, once it has opened
    its DDS sockets (at most :data:`NODE_START_SECONDS`). In the background it
    runs until this process gets SIGTERM, and is stopped then, but never before it has come
    up that way (a signal during Python's imports would not be the clean stop a user sees);
    it marks the current directory with ``.doc-ready-<pid>`` once SIGTERM is handled.
    A node that ends on its own (a bad configuration, a finite run) returns its own status.
    """
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    asked = threading.Event()
    if background:
        signal.signal(signal.SIGTERM, lambda *_: asked.set())
        # The shell that started it waits for this before it sends SIGTERM.
        Path(f'.doc-ready-{os.getpid()}').touch()
    else:
        asked.set()
    process = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                               text=True)
    spoke = threading.Event()

    def echo():
        for line in process.stdout:
            sys.stdout.write(line)
            sys.stdout.flush()
            spoke.set()

    reader = threading.Thread(target=echo, daemon=True)
    reader.start()
    deadline = time.monotonic() + NODE_START_SECONDS
    while (process.poll() is None and not spoke.is_set() and not has_sockets(process.pid)
           and time.monotonic() < deadline):
        time.sleep(0.05)
    end = time.monotonic() + NODE_RUN_SECONDS
    while process.poll() is None and (time.monotonic() < end or not asked.is_set()):
        time.sleep(0.05)
    if process.poll() is None:
        process.send_signal(signal.SIGINT)
    try:
        status = process.wait(timeout=30)
    except subprocess.TimeoutExpired:
        process.kill()
        status = process.wait()
    reader.join(timeout=5)
    return status


if __name__ == '__main__':
    if sys.argv[1] == '--background':
        sys.exit(run_node(sys.argv[2:], background=True))
    sys.exit(run_node(sys.argv[1:]))
