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
One self-contained HTML page per run of a bag tool: figures inline, no network needed.

:class:`HtmlReport` collects headings, text, tables and matplotlib figures (embedded as
base64 PNG) and writes one file. The figure functions draw what the tools report: the
estimate against a reference, the innovations with their +-2 sigma band, the NIS with its
chi-square band, the innovation autocorrelation with its whiteness bounds, the singular
values of a subspace identification and the measured against the simulated output.
"""

import base64
import html
import io
import math
import os
from pathlib import Path
import tempfile
from typing import Callable, Optional, Sequence

import numpy as np

from observer_ros.core.consistency import nis_bounds

#: Points drawn per line at most (longer series are thinned evenly).
MAX_POINTS = 4000

STYLE = """
body { font-family: sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }
h1 { font-size: 1.6em; border-bottom: 2px solid #446; }
h2 { font-size: 1.25em; margin-top: 1.6em; color: #334; }
table { border-collapse: collapse; margin: 0.6em 0; }
td, th { border: 1px solid #bbb; padding: 0.25em 0.6em; text-align: right; }
th { background: #eef; }
td:first-child, th:first-child { text-align: left; }
img { max-width: 100%; display: block; margin: 0.6em 0; }
.good { color: #070; } .bad { color: #a00; }
pre { background: #f6f6f6; padding: 0.6em; overflow-x: auto; }
"""


def write_atomically(target: Path, text: str,
                     check: Optional[Callable[[str], None]] = None) -> Path:
    """
    Write ``text`` to ``target`` under a temporary name, ``check(scratch path)``, rename it.

    A failed check (it raises) or write leaves nothing behind; the file gets mode 0644.
    """
    directory = target.parent if str(target.parent) else Path('.')
    handle, scratch = tempfile.mkstemp(prefix=f'.{target.name}.', dir=directory)
    try:
        with os.fdopen(handle, 'w', encoding='utf-8') as stream:
            stream.write(text)
        if check is not None:
            check(scratch)
        os.chmod(scratch, 0o644)
        os.replace(scratch, target)
    finally:
        if os.path.exists(scratch):
            os.unlink(scratch)
    return target


def _finish(axis, xlabel: str, legend: str = 'upper right') -> None:
    axis.set_xlabel(xlabel)
    axis.legend(loc=legend)
    axis.grid(True)


def _titled(figure, title: str):
    if title:
        figure.suptitle(title)
    figure.tight_layout()
    return figure


def _pyplot():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def thinned(*arrays) -> list:
    """Return the arrays (same length) keeping at most :data:`MAX_POINTS` evenly spread rows."""
    length = len(arrays[0])
    step = max(1, math.ceil(length / MAX_POINTS))
    return [np.asarray(a)[::step] for a in arrays]


class HtmlReport:
    """
    An HTML page being put together; :meth:`write` writes it in one piece.

    Examples
    --------
    >>> report = HtmlReport('demo')
    >>> report.heading('numbers')
    >>> report.table(['name', 'value'], [['a', '1']])
    >>> '<td>a</td>' in report.html()
    True

    """

    def __init__(self, title: str) -> None:
        self.title = title
        self.parts: list = []

    def heading(self, text: str) -> None:
        """Add a section heading."""
        self.parts.append(f'<h2>{html.escape(text)}</h2>')

    def text(self, text: str, verdict: Optional[bool] = None) -> None:
        """Add a paragraph (green when ``verdict`` is True, red when False)."""
        css = '' if verdict is None else f' class="{"good" if verdict else "bad"}"'
        self.parts.append(f'<p{css}>{html.escape(text)}</p>')

    def preformatted(self, text: str) -> None:
        """Add text as printed (tables of numbers)."""
        self.parts.append(f'<pre>{html.escape(text)}</pre>')

    def table(self, header: Sequence[str], rows: Sequence[Sequence]) -> None:
        """Add a table of text cells."""
        head = ''.join(f'<th>{html.escape(str(cell))}</th>' for cell in header)
        body = ''.join('<tr>' + ''.join(f'<td>{html.escape(str(cell))}</td>' for cell in row)
                       + '</tr>' for row in rows)
        self.parts.append(f'<table><tr>{head}</tr>{body}</table>')

    def figure(self, figure, alt: str) -> None:
        """Add a matplotlib figure as an inline PNG (and close it)."""
        buffer = io.BytesIO()
        figure.savefig(buffer, format='png', dpi=90)
        _pyplot().close(figure)
        data = base64.b64encode(buffer.getvalue()).decode('ascii')
        self.parts.append(f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">')

    def html(self) -> str:
        """Return the page."""
        title = html.escape(self.title)
        return (f'<!DOCTYPE html>\n<html lang="en"><head><meta charset="utf-8">'
                f'<title>{title}</title><style>{STYLE}</style></head><body>'
                f'<h1>{title}</h1>\n' + '\n'.join(self.parts) + '\n</body></html>\n')

    def write(self, path) -> Path:
        """Write the page to ``path`` under a temporary name renamed into place."""
        target = Path(path)
        target.parent.mkdir(parents=True, exist_ok=True)
        return write_atomically(target, self.html())


def _seconds(stamps_ns, origin_ns: int) -> np.ndarray:
    return (np.asarray(stamps_ns, dtype=np.int64) - origin_ns) / 1e9


def states_figure(stamps_ns, estimates, names: Sequence[str], truth_stamps_ns=None, truth=None,
                  title: str = ''):
    """Plot ``x_hat`` per state, with the reference (``x_true``) where there is one."""
    plt = _pyplot()
    count = len(names)
    columns = 2 if count > 1 else 1
    rows = math.ceil(count / columns)
    figure, axes = plt.subplots(rows, columns, figsize=(11, 2.6 * rows), squeeze=False)
    origin = int(stamps_ns[0])
    times, values = thinned(_seconds(stamps_ns, origin), estimates)
    if truth is not None:
        truth_times, truth_values = thinned(_seconds(truth_stamps_ns, origin), truth)
    for index, name in enumerate(names):
        axis = axes[index // columns][index % columns]
        if truth is not None:
            axis.plot(truth_times, truth_values[:, index], 'b', linewidth=1.5,
                      label=f'{name} reference')
        axis.plot(times, values[:, index], 'r--', linewidth=1, label=f'{name} estimate')
        _finish(axis, 'time [s]', 'best')
    for index in range(count, rows * columns):
        axes[index // columns][index % columns].axis('off')
    return _titled(figure, title)


def innovations_figure(stamps_ns, innovations, covariance, names: Sequence[str],
                       title: str = ''):
    """Plot each innovation with its +-2 sigma band (``sigma^2`` the diagonal of ``S``)."""
    plt = _pyplot()
    count = len(names)
    figure, axes = plt.subplots(count, 1, figsize=(11, 2.4 * count), squeeze=False)
    times, values = thinned(_seconds(stamps_ns, int(stamps_ns[0])), innovations)
    sigma = np.sqrt(np.diag(np.atleast_2d(covariance)))
    for index, name in enumerate(names):
        axis = axes[index][0]
        inside = np.mean(np.abs(innovations[:, index]) <= 2 * sigma[index])
        axis.plot(times, values[:, index], 'k', linewidth=0.5, label=f'innovation {name}')
        axis.axhline(2 * sigma[index], color='r', linestyle='--',
                     label=f'+-2 sigma ({inside:.1%} inside; 95.4% expected)')
        axis.axhline(-2 * sigma[index], color='r', linestyle='--')
        _finish(axis, 'time [s]')
    return _titled(figure, title)


def nis_figure(stamps_ns, nis, n_outputs: int, window: int = 100, title: str = ''):
    """Plot the NIS averaged over ``window`` samples, with the 99 % chi-square band."""
    plt = _pyplot()
    from observer_ros.core.tuning.innovations import moving_mean
    figure, axis = plt.subplots(1, 1, figsize=(11, 3))
    window = max(1, min(int(window), len(nis)))
    mean = moving_mean(nis, window)
    times, values = thinned(_seconds(stamps_ns, int(stamps_ns[0])), mean)
    low, high = nis_bounds(window, n_outputs, 0.99)
    axis.plot(times, values, 'k', linewidth=0.8, label=f'NIS, mean of {window}')
    axis.axhspan(low, high, color='g', alpha=0.15, label=f'99% chi-square band ({low:.3g} .. '
                 f'{high:.3g})')
    axis.axhline(n_outputs, color='g', linestyle=':', label=f'expected {n_outputs}')
    _finish(axis, 'time [s]')
    if title:
        axis.set_title(title)
    figure.tight_layout()
    return figure


def autocorrelation_figure(correlation, bound: float, names: Sequence[str], title: str = ''):
    """Plot each output's normalized innovation autocorrelation, with +-bound."""
    plt = _pyplot()
    count = len(names)
    figure, axes = plt.subplots(1, count, figsize=(11, 3), squeeze=False)
    lags = np.arange(len(correlation))
    for index, name in enumerate(names):
        axis = axes[0][index]
        axis.stem(lags[1:], correlation[1:, index, index], basefmt='k-')
        axis.axhline(bound, color='r', linestyle='--', label=f'+-{bound:.3g} (white, 95%)')
        axis.axhline(-bound, color='r', linestyle='--')
        axis.set_title(f'autocorrelation of {name}')
        _finish(axis, 'lag [samples]')
    return _titled(figure, title)


def singular_values_figure(values, order: int):
    """Plot the singular values of the subspace step (log scale), the order marked."""
    plt = _pyplot()
    figure, axis = plt.subplots(1, 1, figsize=(8, 3))
    index = np.arange(1, len(values) + 1)
    axis.semilogy(index, values, 'ko-')
    axis.axvline(order + 0.5, color='r', linestyle='--', label=f'order {order}')
    axis.set_xlabel('index')
    axis.set_ylabel('singular value')
    axis.legend(loc='upper right')
    axis.grid(True, which='both')
    figure.tight_layout()
    return figure


def fit_figure(times, measured, simulated, names: Sequence[str], fits, title: str = ''):
    """Plot measured against simulated output on the held-out data, with each fit."""
    plt = _pyplot()
    count = len(names)
    figure, axes = plt.subplots(count, 1, figsize=(11, 2.6 * count), squeeze=False)
    times, measured, simulated = thinned(times, measured, simulated)
    for index, name in enumerate(names):
        axis = axes[index][0]
        axis.plot(times, measured[:, index], 'b', linewidth=1, label=f'{name} measured')
        axis.plot(times, simulated[:, index], 'r--', linewidth=1,
                  label=f'{name} simulated (fit {fits[index]:.1f}%)')
        _finish(axis, 'time [s]')
    return _titled(figure, title)


__all__ = ['HtmlReport', 'autocorrelation_figure', 'fit_figure', 'innovations_figure',
           'nis_figure', 'singular_values_figure', 'states_figure', 'thinned', 'write_atomically']


def filter_run_section(report: HtmlReport, heading: str, stamps_ns, estimates, innovations,
                       innovation_covariance, nis, state_names: Sequence[str],
                       output_names: Sequence[str], correlation=None, bound: float = 0.0,
                       truth_stamps_ns=None, truth=None) -> None:
    """
    Add one filter run: estimates (against the reference), innovations, NIS, autocorrelation.

    ``correlation`` (lags, p, p) and ``bound`` come from
    :func:`observer_ros.core.tuning.innovations.whiteness`; the panel is left out without.
    """
    report.heading(heading)
    if len(stamps_ns) == 0:
        report.text('no estimates')
        return
    reference = 'against x_true' if truth is not None else '(no reference in the bag)'
    report.figure(states_figure(stamps_ns, estimates, state_names, truth_stamps_ns, truth,
                                f'x_hat {reference}'), f'{heading}: estimates')
    if innovation_covariance is not None:
        report.figure(innovations_figure(stamps_ns, innovations, innovation_covariance,
                                         output_names, 'innovations'),
                      f'{heading}: innovations')
    if nis is not None:
        report.figure(nis_figure(stamps_ns, nis, len(output_names), title='NIS'),
                      f'{heading}: NIS')
    if correlation is not None:
        report.figure(autocorrelation_figure(correlation, bound, output_names),
                      f'{heading}: innovation autocorrelation')


__all__ += ['filter_run_section']
