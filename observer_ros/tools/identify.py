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
``identify``: a linear model of a chosen order from recorded inputs and outputs.

``identify BAG... --order N [--inputs TOPIC ...] [--outputs TOPIC ...] [-o model.yaml]``
reads the input and output topics of the bags (or folders of bags; in worker processes, or
on a Dask cluster with ``--dask``), identifies ``A``, ``B``, ``C``, ``D`` by subspace
identification (PO-MOESP) from all but the last ``--holdout`` of each recording, and prints
the singular values to choose the order from, the poles and the fit on the held-out part
(as MATLAB's ``compare``). ``--feedthrough fit`` fits ``D`` too (default ``zero``).
``--continuous`` converts the model to continuous time (zero-order hold inverted). ``-o``
writes a parameter file with the model and a Kalman filter to start from (``R`` the
residual covariance; tune both noises with ``tune_kalman``); ``--report DIR`` writes
``DIR/identify.html``. An error prints one line, exits with status 2 and writes nothing.
"""

import argparse
from pathlib import Path
import sys

import numpy as np

from observer_ros.app.parallel import add_worker_arguments, single_threaded_blas, task_mapper
from observer_ros.app.run_report import fit_figure, HtmlReport, singular_values_figure
from observer_ros.bags.filter_config import model_document, write_validated
from observer_ros.bags.identification import HOLDOUT, Identification, identify_bags, SignalSpec
from observer_ros.bags.reading import TopicRequest
from observer_ros.bags.signals import PERIOD_TOLERANCE
from observer_ros.config.schema import INPUT_MESSAGE_TYPES
from observer_ros.core.tuning.subspace import FEEDTHROUGH_CHOICES, order_advice
from observer_ros.signals import stops_on_signal
from observer_ros.tools.outputs import run_tool

REPORT_NAME = 'identify'

#: ``--feedthrough`` by default: ``D`` fixed at zero (see doc/nodes/identify.md for why).
FEEDTHROUGH = 'zero'

#: Process noise of the Kalman filter written with the model, relative to the trace of the
#: residual covariance per state: a starting value for tune_kalman.
START_PROCESS_NOISE = 0.01


def _poles_text(poles) -> str:
    return ', '.join(f'{p.real:.6g}' if abs(p.imag) < 1e-12 else f'{p.real:.6g}{p.imag:+.6g}j'
                     for p in sorted(poles, key=lambda p: (p.real, p.imag)))


def _matrix(name, matrix) -> str:
    rows = np.atleast_2d(matrix)
    if not rows.size:
        return f'{name} = (empty)'
    return f'{name} =\n' + '\n'.join('    ' + '  '.join(f'{v:12.6g}' for v in row)
                                     for row in rows)


def summary(result: Identification, order: int) -> str:
    """Return the printed summary."""
    model = result.model
    values = model.singular_values
    shown = ' '.join(f'{v:.4g}' for v in values[:max(order + 4, 8)])
    names = result.signals[0]
    lines = [f'{len(result.signals)} bag(s): inputs {", ".join(names.input_names)}; outputs '
             f'{", ".join(names.output_names)}; every {result.period_ns / 1e6:g} ms; '
             f'{result.estimation_samples} samples to identify from, '
             f'{result.validation_samples} held out',
             f'singular values (horizon {model.horizon}): {shown}',
             order_advice(values, order),
             f'order {order}, discrete (dt = {model.dt:g} s) poles: {_poles_text(model.poles)}']
    if result.continuous is not None:
        poles = np.linalg.eigvals(result.continuous[0])
        lines.append(f'continuous poles: {_poles_text(poles)}')
        a, b = result.continuous
    else:
        a, b = model.a, model.b
    lines += [_matrix('A', a), _matrix('B', b), _matrix('C', model.c), _matrix('D', model.d)]
    fits = ', '.join(f'{name} {fit:.2f}%' for name, fit in zip(names.output_names, result.fit))
    lines.append(f'fit on the held-out data: {fits}')
    lines += _resampling_lines(result)
    return '\n'.join(lines)


def _resampling_lines(result: Identification) -> list:
    """Say what resampling did to each bag, and the fit of the raw samples beside it."""
    lines = []
    names = result.signals[0].output_names
    for item in result.signals:
        note = item.resampling
        if note is None:
            continue
        errors = ', '.join(f'{name} {rms:.3g} ({rms / scale if scale else 0.0:.1%} of its RMS)'
                           for name, rms, scale in zip(names, note.interpolation_rms,
                                                       note.output_rms))
        lines.append(f'resampled {item.bag}: {note.raw_samples} measurements (intervals '
                     f'{note.raw_min_ns / 1e6:g} .. {note.raw_max_ns / 1e6:g} ms, median '
                     f'{note.raw_median_ns / 1e6:g} ms, {note.uneven} off it by more than '
                     f'{PERIOD_TOLERANCE:.0%}) onto {note.samples} points every '
                     f'{note.period_ns / 1e6:g} ms in {note.records} stretch'
                     f'{"" if note.records == 1 else "es"} (inputs zero-order held, outputs '
                     f'linearly interpolated); grid interpolated back at the measured stamps: '
                     f'RMS error {errors}')
    if result.raw_fit is not None:
        fits = ', '.join(f'{name} {fit:.2f}%' for name, fit in zip(names, result.raw_fit))
        lines.append(f'fit of the raw samples taken as evenly spaced (not resampled): {fits}')
    elif result.raw_fit_error:
        lines.append(f'the raw samples taken as evenly spaced give no model: '
                     f'{result.raw_fit_error}')
    return lines


def model_text(result: Identification, text: str) -> str:
    """Return the parameter file of the model (the summary as comments on top)."""
    import yaml
    model = result.model
    signals = result.signals[0]
    a, b = result.continuous if result.continuous is not None else (model.a, model.b)
    dt = 0.0 if result.continuous is not None else model.dt
    n_states = len(a)
    r = result.residual_covariance
    q = np.eye(n_states) * START_PROCESS_NOISE * float(np.trace(r)) / n_states
    topics = {}
    for role, chosen in (('u', signals.input_topics), ('y', signals.output_topics)):
        if len(chosen) == 1 and isinstance(chosen[0], TopicRequest):
            topics[role] = {'type': chosen[0].kind, 'field': chosen[0].field}
        elif len(chosen) == 1 and role == 'u' and chosen[0].kind in INPUT_MESSAGE_TYPES:
            topics[role] = {'type': chosen[0].kind, 'fields': list(chosen[0].fields)}
    document = model_document(a, b, model.c, model.d, dt,
                              [f'x{i + 1}' for i in range(n_states)], signals.input_names,
                              signals.output_names, r, q, topics)
    if result.continuous is not None:
        document['/**']['ros__parameters']['plant'] = {'rate_hz': 1e9 / result.period_ns}
    header = ('Identified by identify (subspace, PO-MOESP). The Kalman noises are starting\n'
              'values (R: the residual covariance); tune them with tune_kalman.\n' + text)
    comments = ''.join(f'# {line}\n'.replace('# \n', '#\n') for line in header.splitlines())
    return comments + yaml.safe_dump(document, sort_keys=False, default_flow_style=None,
                                     width=99)


def write_report(directory, result: Identification, order: int, text: str) -> Path:
    """Write ``DIRECTORY/identify.html``; return its path."""
    report = HtmlReport(f'identify: order {order}, {len(result.signals)} bag(s)')
    report.preformatted(text)
    report.heading('singular values')
    report.figure(singular_values_figure(result.model.singular_values, order),
                  'singular values')
    report.heading('held-out data: measured against simulated output')
    stamps, measured, simulated = result.validation[0]
    times = (stamps - stamps[0]) / 1e9
    report.figure(fit_figure(times, measured, simulated, result.signals[0].output_names,
                             result.fit, f'{result.signals[0].bag} (held-out part)'),
                  'measured against simulated output')
    return report.write(Path(directory) / f'{REPORT_NAME}.html')


@stops_on_signal('identify')
def main(args=None) -> int:
    """Entry point of ``identify`` (also ``ros2 run observer_ros identify``)."""
    parser = argparse.ArgumentParser(
        prog='identify', description='Identify a linear model (A, B, C, D) of a chosen order '
        'from recorded inputs and outputs (subspace identification).')
    parser.add_argument('bags', nargs='+', metavar='BAG', help='rosbag2 bags or folders of bags')
    parser.add_argument('--order', type=int, required=True, help='number of states n')
    # extend: a repeated option adds its topics (it used to keep only the last one).
    parser.add_argument('--inputs', nargs='+', action='extend', default=None, metavar='TOPIC',
                        help='input topics, TOPIC[:FIELD[:JOINT,...]] or '
                        'TOPIC:PATH[,PATH...] (default u; repeatable)')
    parser.add_argument('--outputs', nargs='+', action='extend', default=None,
                        metavar='TOPIC', help='output topics, TOPIC[:FIELD[:JOINT,...]] or '
                        'TOPIC:PATH[,PATH...] (default y; repeatable)')
    parser.add_argument('--continuous', action='store_true',
                        help='write the continuous model (zero-order hold inverted)')
    parser.add_argument('--feedthrough', choices=FEEDTHROUGH_CHOICES, default=FEEDTHROUGH,
                        help=f'fit D by least squares, or fix it at zero (default '
                        f'{FEEDTHROUGH}: a plant sampled behind a zero-order hold has none)')
    parser.add_argument('--holdout', type=float, default=HOLDOUT,
                        help=f'fraction held out at the end of each recording (default '
                        f'{HOLDOUT})')
    parser.add_argument('--horizon', type=int, default=None,
                        help='block rows of the Hankel matrices (default max(2 n, 20))')
    parser.add_argument('--use-log-time', action='store_true',
                        help='stamp every topic with its log times instead of its header '
                        'stamps (inputs without a header in a bag recorded in sim time)')
    parser.add_argument('--resample', metavar='RATE', default=None,
                        help='resample unevenly sampled recordings onto a uniform grid of RATE '
                        'Hz, or auto (the median measurement interval): inputs zero-order '
                        'held, outputs linearly interpolated')
    parser.add_argument('-o', '--output', metavar='FILE', help='write the model parameter file')
    parser.add_argument('--report', metavar='DIR', help='write DIR/identify.html')
    add_worker_arguments(parser, 'read')
    options = parser.parse_args(args)
    with single_threaded_blas():
        return _run(options)


def _run(options) -> int:
    def compute(bags):
        inputs = [SignalSpec.parse(text) for text in options.inputs or ['u']]
        outputs = [SignalSpec.parse(text) for text in options.outputs or ['y']]
        with task_mapper(options.workers, options.dask) as mapper:
            result = identify_bags(bags, inputs, outputs, options.order, mapper, options.holdout,
                                   options.horizon, options.continuous, options.use_log_time,
                                   options.resample, options.feedthrough)
        return result, summary(result, options.order)

    return run_tool(
        'identify', options, compute,
        lambda result, text: write_validated(Path(options.output), model_text(result, text)),
        'model', lambda result, text: write_report(options.report, result, options.order, text))


if __name__ == '__main__':
    sys.exit(main())
