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

"""PNG figures of an estimation run, in the style of the seeds' figures."""

import math
import os

import numpy as np

from observer_ros.core.evaluation import (
    align, decay_rate, error_report, ErrorReport, format_error_table, settling_time)


def plot_estimation(path: str, report: ErrorReport, truth: np.ndarray, estimate: np.ndarray,
                    decay: float, title: str = '') -> None:
    """
    Write a PNG: ``x`` and ``x_hat`` per state, and the error norm on a log scale.

    The error-norm panel also draws the designed envelope ``||e(0)|| exp(-decay t)``.
    """
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    n_states = truth.shape[1]
    columns = 2
    rows = math.ceil(n_states / columns) + 1
    figure, axes = plt.subplots(rows, columns, figsize=(11, 2.6 * rows), squeeze=False)
    times = report.times
    for index in range(n_states):
        axis = axes[index // columns][index % columns]
        axis.plot(times, truth[:, index], 'b', linewidth=2, label=f'{report.names[index]}(t)')
        axis.plot(times, estimate[:, index], 'r--', linewidth=1.5,
                  label=f'{report.names[index]} estimate')
        axis.axhline(0.0, color='k', linewidth=0.5)
        axis.set_xlabel('time [s]')
        axis.legend(loc='best')
        axis.grid(True)
    for index in range(n_states, (rows - 1) * columns):
        axes[index // columns][index % columns].axis('off')
    error_axis = plt.subplot2grid((rows, columns), (rows - 1, 0), colspan=columns, fig=figure)
    for axis in axes[rows - 1]:
        axis.remove()
    norms = np.linalg.norm(report.error, axis=1)
    floor = 1e-16
    error_axis.semilogy(times, np.maximum(norms, floor), 'k', label='||x - x_hat||')
    if decay > 0 and norms[0] > 0:
        error_axis.semilogy(times, np.maximum(norms[0] * np.exp(-decay * times), floor), 'g:',
                            label=f'designed envelope exp({-decay:.3g} t)')
    error_axis.axvline(report.settling_time, color='gray', linestyle='--',
                       label='designed settling time')
    error_axis.set_xlabel('time [s]')
    error_axis.set_ylabel('error norm')
    error_axis.grid(True, which='both')
    error_axis.legend(loc='best')
    if title:
        figure.suptitle(title)
    figure.tight_layout()
    figure.savefig(path, dpi=100)
    plt.close(figure)


def write_run_report(directory: str, name: str, system, truth_stamps, truth, stamps,
                     estimates, title: str = '') -> str:
    """
    Compare ``x_hat`` with ``x_true`` of one run: the printed table and ``DIRECTORY/NAME.png``.

    Parameters
    ----------
    directory, name : str
        Where the PNG goes (``name`` without extension).
    system : observer_ros.config.Configuration
        Gives the state names and the designed poles (settling time, decay envelope).
    truth_stamps, truth, stamps, estimates : numpy.ndarray
        Both series; they are compared at the stamps they share.

    Returns
    -------
    str
        The error table followed by the path of the plot.

    Raises
    ------
    ValueError
        When the two series share no stamp.

    """
    common, truth, estimates = align(truth_stamps, truth, stamps, estimates)
    if not len(common):
        raise ValueError('x_true and x_hat share no stamp: nothing to compare')
    estimates = system.observer.angles.states_near(estimates, truth)  # errors, not turns
    dt = system.model.dt
    poles = system.observer.design.achieved_poles
    report = error_report(common, truth, estimates, system.model.state_names,
                          settling_time(poles, dt))
    os.makedirs(directory, exist_ok=True)
    path = os.path.join(directory, f'{name}.png')
    plot_estimation(path, report, truth, estimates, decay_rate(poles, dt), title=title)
    return format_error_table(report) + f'\nplot: {path}'
