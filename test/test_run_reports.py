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
The HTML reports of ``replay``, ``tune_kalman`` and ``identify``, opened in a real browser.

:func:`check_page` is used here and by ``test_tuning_doc.py``, which renders the reports of
the documentation's worked example.

Each page is self-contained (inline PNG figures, no network) and headless Chromium renders
it: the screenshot has the asked size, is not blank and shows the figures' coloured lines.
Chromium comes from Debian's packages (``scripts/setup_env.sh`` installs it when run as root
on a machine with apt-get); without it the browser check fails under CI and is skipped
elsewhere.
"""

import os
from pathlib import Path
import re
import shutil
import subprocess

import numpy as np
import pytest

from observer_ros.tools.replay import main as replay_main
from tuning_support import COUPLED

WIDTH, HEIGHT = 1200, 2400
BROWSERS = ('chromium', 'chromium-browser', 'google-chrome')


def browser() -> str:
    """Return the headless browser, or fail (CI) / skip (elsewhere) without one."""
    for name in BROWSERS:
        found = shutil.which(name)
        if found:
            return found
    message = ('no Chromium found (install it: apt-get install chromium; scripts/setup_env.sh '
               'does when run as root)')
    if os.environ.get('CI'):
        pytest.fail(message)
    pytest.skip(message)


def screenshot(page: Path, tmp_path: Path) -> np.ndarray:
    """Render ``page`` in headless Chromium; return the screenshot's pixels (RGB, 0..1)."""
    shot = tmp_path / f'{page.stem}.png'
    command = [browser(), '--headless', '--no-sandbox', '--disable-gpu',
               '--disable-background-networking', '--disable-component-update',
               '--disable-sync', '--no-first-run', f'--user-data-dir={tmp_path / "profile"}',
               f'--window-size={WIDTH},{HEIGHT}', f'--screenshot={shot}', page.as_uri()]
    subprocess.run(command, capture_output=True, timeout=120, check=True)
    import matplotlib.image
    return matplotlib.image.imread(str(shot))[:, :, :3]


def check_page(page: Path, tmp_path: Path, figures: int, words, render: bool = True) -> None:
    text = page.read_text()
    sources = re.findall(r'src="([^"]*)"', text)
    assert len(sources) == figures and all(s.startswith('data:image/png;base64,')
                                           for s in sources)
    markup = re.sub(r'src="data:[^"]*"', '', text)  # base64 may hold '//'
    assert not re.search(r'https?:|//[a-z]|<script|<link', markup)
    for word in words:
        assert word in text
    if not render:
        return
    pixels = screenshot(page, tmp_path)
    assert pixels.shape == (HEIGHT, WIDTH, 3)
    ink = np.mean(pixels.min(axis=2) < 0.9)  # anything not white
    red = np.mean((pixels[:, :, 0] > 0.7) & (pixels[:, :, 1] < 0.4) & (pixels[:, :, 2] < 0.4))
    blue = np.mean((pixels[:, :, 2] > 0.7) & (pixels[:, :, 0] < 0.4))
    print(f'{page.name}: {ink:.1%} of the screenshot inked, red {red:.3%}, blue {blue:.3%}')
    assert ink > 0.015 and red > 1e-4 and blue > 1e-4


def test_a_single_bag_replay_report_renders_in_a_browser(tmp_path, capsys):
    browser()
    COUPLED.write_bag(tmp_path / 'run', 1500, seed=1)
    params = COUPLED.write_parameters(tmp_path / 'params.yaml')
    assert replay_main([str(tmp_path / 'run'), params, '--report', str(tmp_path / 'single')]) == 0
    assert 'report: ' in capsys.readouterr().out
    assert (tmp_path / 'single' / 'replay.png').exists()  # the error plot, as before
    check_page(tmp_path / 'single' / 'replay.html', tmp_path, 4,
               ['replay: kalman observer', 'run'])
