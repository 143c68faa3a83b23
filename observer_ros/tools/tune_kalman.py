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
``tune_kalman``: Kalman noise covariances from recordings, by autocovariance least squares.

``tune_kalman BAG... PARAMS [-o tuned.yaml] [--report DIR]`` runs the filter of PARAMS over
the bags (or folders of bags; in worker processes, or on a Dask cluster with ``--dask``),
pools the innovations, estimates ``Q`` (``observer.process_noise``) and ``R``
(``observer.measurement_noise``) with the structure asked for, runs the tuned filter, and
prints the estimates, the entries the data cannot identify, and the NIS and whiteness before
and after. ``-o`` writes PARAMS with the tuned noises (validated first; the summary as
comments on top); ``--report DIR`` writes ``DIR/tune_kalman.html`` and
``DIR/tune_kalman.json``. An error prints one line, exits with status 2 and writes nothing.

``--inputs``/``--outputs`` read other topics by field path, with ``identify``'s reader
(:mod:`observer_ros.bags.signals`); ``--use-log-time`` stamps them with their log times and
``--resample`` puts them onto a uniform grid as ``identify`` does. A tuning that fails its
own checks (innovations not white after tuning, a zero ``Q``) says so, writes no ``-o``
file and exits with status 3 (:data:`~observer_ros.bags.tuning.FAILED_CHECKS_STATUS`)
unless ``--accept-failed-checks``.
"""

import argparse
import json
from pathlib import Path
import re
import sys

import numpy as np

from observer_ros.app.parallel import add_worker_arguments, single_threaded_blas, task_mapper
from observer_ros.app.run_report import filter_run_section, HtmlReport
from observer_ros.bags.filter_config import load_kalman_setup
from observer_ros.bags.innovation_runs import SignalChoice
from observer_ros.bags.paired_signals import resample_period
from observer_ros.bags.signals import SignalSpec
from observer_ros.bags.tuning import (
    FAILED_CHECKS_STATUS, ITERATIONS, normalized_squares, tune_noises, TuningRun)
from observer_ros.core.errors import ConfigError
from observer_ros.core.tuning.als import WEIGHTINGS
from observer_ros.core.tuning.noise_model import NoiseStructure, STRUCTURES
from observer_ros.signals import stops_on_signal
from observer_ros.tools.outputs import run_tool

REPORT_NAME = 'tune_kalman'
KNOWN = re.compile(r'^\s*([QR])\[\s*([^,\]]+?)\s*,\s*([^\]]+?)\s*\]\s*=\s*(.+)$')


def parse_known(texts, state_names, output_names) -> dict:
    """
    Parse ``--known Q[i,j]=value`` entries (names or zero-based indices).

    Raises
    ------
    ConfigError
        Naming ``--known``: the form, an unknown name, or a value that is no number.

    """
    known = {}
    for text in texts:
        match = KNOWN.match(text)
        if not match:
            raise ConfigError('--known', f'expected Q[row,column]=value or R[row,column]='
                              f'value (names or indices from 0), got {text!r}')
        symbol, row, column, value = match.groups()
        names = state_names if symbol == 'Q' else output_names
        indices = []
        for item in (row, column):
            if item in names:
                indices.append(list(names).index(item))
            elif item.isdigit() and int(item) < len(names):
                indices.append(int(item))
            else:
                raise ConfigError('--known', f'{item!r} in {text!r} is no '
                                  f'{"state" if symbol == "Q" else "output"} ({", ".join(names)}'
                                  f', or 0..{len(names) - 1})')
        try:
            number = float(value)
        except ValueError:
            raise ConfigError('--known', f'{value!r} in {text!r} is not a number') from None
        known[(symbol, *indices)] = number
    return known


def _matrix_text(name: str, matrix) -> str:
    rows = np.atleast_2d(matrix)
    return f'{name} =\n' + '\n'.join('    ' + '  '.join(f'{v:12.6g}' for v in row)
                                     for row in rows)


def _judgement(pooled) -> str:
    nis, white = pooled.nis, pooled.whiteness
    verdict = 'consistent' if nis.consistent else 'NOT consistent'
    ljung = ', '.join(f'{p:.3g}' for p in white.p_values)
    return (f'NIS mean {nis.mean:.4g} (band {nis.low:.4g} .. {nis.high:.4g} for '
            f'{nis.samples} samples, {verdict}); whiteness: {white.outside:.1%} of the '
            f'autocorrelations outside +-{white.bound:.3g} (5% expected when white), '
            f'Ljung-Box p {ljung} ({"white" if white.white else "NOT white"})')


def summary(outcome: TuningRun, bags) -> str:
    """Return the printed summary of a tuning."""
    first, last = outcome.setups[0], outcome.tuned
    estimate = outcome.final
    pooled = outcome.pooled
    lines = [f'{len(bags)} bag{"s" if len(bags) > 1 else ""}, '
             f'{sum(len(r.stamps_ns) for r in outcome.runs[0])} samples every '
             f'{outcome.period_ns / 1e6:g} ms; {pooled[-2].statistics.segments} segments, '
             f'burn-in {pooled[-2].burn_in}, {outcome.lags[-2]} lags, '
             f'{len(outcome.estimates)} iteration{"s" if len(outcome.estimates) > 1 else ""}, '
             f'{estimate.method}',
             _matrix_text('initial Q (observer.process_noise)', first.process_noise),
             _matrix_text('initial R (observer.measurement_noise)', first.measurement_noise),
             _matrix_text('tuned Q (observer.process_noise)', last.process_noise),
             _matrix_text('tuned R (observer.measurement_noise)', last.measurement_noise),
             f'ALS system: rank {estimate.rank} of {estimate.n_parameters} free entries, '
             f'relative residual {estimate.residual:.3g}']
    if estimate.unidentifiable:
        lines.append(f'not identifiable from the innovations: '
                     f'{", ".join(estimate.unidentifiable)} (least-norm values; they change '
                     f'neither the filter gain nor the innovation covariance)')
    lines.append(f'before: {_judgement(pooled[0])}')
    lines.append(f'after:  {_judgement(pooled[-1])}')
    failed = outcome.failed_checks
    lines += ([f'FAILED check: {text}' for text in failed] if failed else
              ['checks passed: white innovations after tuning, Q not zero'])
    return '\n'.join(lines)


def _statistics(pooled) -> dict:
    return {'nis_mean': pooled.nis.mean, 'nis_band': [pooled.nis.low, pooled.nis.high],
            'nis_consistent': pooled.nis.consistent, 'samples': pooled.nis.samples,
            'whiteness_outside': pooled.whiteness.outside,
            'whiteness_bound': pooled.whiteness.bound,
            'ljung_box_p': pooled.whiteness.p_values.tolist(),
            'white': pooled.whiteness.white}


def summary_json(outcome: TuningRun, bags) -> dict:
    """Return the tuning as JSON types (the report's data file)."""
    return {'bags': list(bags), 'period_s': outcome.period_ns / 1e9, 'lags': outcome.lags,
            'burn_in': [p.burn_in for p in outcome.pooled],
            'initial': {'process_noise': outcome.setups[0].process_noise.tolist(),
                        'measurement_noise': outcome.setups[0].measurement_noise.tolist()},
            'tuned': {'process_noise': outcome.tuned.process_noise.tolist(),
                      'measurement_noise': outcome.tuned.measurement_noise.tolist()},
            'unidentifiable': list(outcome.final.unidentifiable),
            'method': outcome.final.method, 'rank': outcome.final.rank,
            'before': _statistics(outcome.pooled[0]), 'after': _statistics(outcome.pooled[-1]),
            'failed_checks': outcome.failed_checks}


def write_report(directory, outcome: TuningRun, bags, text: str) -> Path:
    """Write ``DIRECTORY/tune_kalman.html`` (and ``.json``); return the HTML path."""
    setup = outcome.tuned
    report = HtmlReport(f'tune_kalman: {len(bags)} bag{"s" if len(bags) > 1 else ""}')
    report.preformatted(text)
    for label, index in (('before: the filter of the parameter file', 0),
                         ('after: the tuned filter', -1)):
        pooled = outcome.pooled[index]
        report.text(f'{label}: {_judgement(pooled)}',
                    pooled.nis.consistent and pooled.whiteness.white)
    for label, index in (('before', 0), ('after', -1)):
        run = outcome.runs[index][0]
        pooled = outcome.pooled[index]
        covariance = outcome.innovation_covariance(index)
        filter_run_section(report, f'{label}: {run.bag}', run.stamps_ns, run.estimates,
                           run.innovations, covariance,
                           normalized_squares(run.innovations, covariance),
                           setup.state_names, setup.output_names,
                           pooled.whiteness.correlation, pooled.whiteness.bound,
                           run.truth_stamps_ns, run.truth)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    (directory / f'{REPORT_NAME}.json').write_text(
        json.dumps(summary_json(outcome, bags), indent=1) + '\n', encoding='utf-8')
    return report.write(directory / f'{REPORT_NAME}.html')


@stops_on_signal('tune_kalman')
def main(args=None) -> int:
    """Entry point of ``tune_kalman`` (also ``ros2 run observer_ros tune_kalman``)."""
    parser = argparse.ArgumentParser(
        prog='tune_kalman', description='Estimate the Kalman noise covariances Q and R from '
        'recorded bags (autocovariance least squares) and write a tuned parameter file.')
    parser.add_argument('bags', nargs='+', metavar='BAG', help='rosbag2 bags or folders of bags')
    parser.add_argument('params', metavar='PARAMS',
                        help='parameter file of the Kalman filter that runs first')
    parser.add_argument('-o', '--output', metavar='FILE',
                        help='write PARAMS with the tuned noises to FILE')
    parser.add_argument('--report', metavar='DIR',
                        help='write DIR/tune_kalman.html and DIR/tune_kalman.json')
    parser.add_argument('--process-structure', choices=STRUCTURES, default='diagonal',
                        help='structure of Q (default diagonal)')
    parser.add_argument('--measurement-structure', choices=STRUCTURES, default='full',
                        help='structure of R (default full)')
    parser.add_argument('--known', action='append', default=[], metavar='Q[i,j]=VALUE',
                        help='an entry of Q or R known, by state/output names or indices from '
                        '0, e.g. "Q[position,position]=0" (repeatable)')
    parser.add_argument('--lags', type=int, default=None,
                        help='autocovariance lags (default: from the filter, 4..50)')
    parser.add_argument('--burn-in', type=int, default=None,
                        help='samples left out at the start of each segment (default: until '
                        'the start-up transient has faded to 1e-12)')
    parser.add_argument('--iterations', type=int, default=ITERATIONS,
                        help=f'estimate, rerun the tuned filter, estimate again '
                        f'(default {ITERATIONS})')
    parser.add_argument('--weighting', choices=WEIGHTINGS, default='whitened')
    parser.add_argument('--y-topic', default='y', help='measurement topic in the bags')
    parser.add_argument('--u-topic', default='u', help='input topic in the bags')
    # extend: a repeated option adds its topics (it used to keep only the last one).
    parser.add_argument('--inputs', nargs='+', action='extend', default=[], metavar='TOPIC',
                        help='read the inputs as identify does: TOPIC[:FIELD[:JOINT,...]] or '
                        'TOPIC:PATH[,PATH...] (one topic; default: topics.u of PARAMS on '
                        '--u-topic)')
    parser.add_argument('--outputs', nargs='+', action='extend', default=[], metavar='TOPIC',
                        help='read the outputs as identify does (several topics when stamped '
                        'together; default: topics.y of PARAMS on --y-topic)')
    parser.add_argument('--use-log-time', action='store_true',
                        help='stamp every topic with its log times instead of its header '
                        'stamps (inputs without a header in a bag recorded in sim time)')
    parser.add_argument('--resample', metavar='RATE', default=None,
                        help='resample onto a uniform grid of RATE Hz, or auto, as identify '
                        'does: inputs zero-order held, outputs linearly interpolated')
    parser.add_argument('--accept-failed-checks', action='store_true',
                        help=f'write the tuned file and exit 0 even when the tuning failed '
                        f'its checks (innovations not white after tuning, Q zero); without '
                        f'it such a tuning writes no -o file and exits with '
                        f'{FAILED_CHECKS_STATUS}')
    add_worker_arguments(parser, 'run')
    options = parser.parse_args(args)
    with single_threaded_blas():
        return _run(options)


def _run(options) -> int:
    def compute(bags):
        setup = load_kalman_setup(options.params)
        known = parse_known(options.known, setup.state_names, setup.output_names)
        structure = NoiseStructure.build(setup.model.n_states, setup.model.n_outputs,
                                         options.process_structure,
                                         options.measurement_structure, known)
        resample_period(options.resample, 1)  # a bad --resample fails before any bag is read
        choice = SignalChoice(tuple(SignalSpec.parse(text) for text in options.inputs),
                              tuple(SignalSpec.parse(text) for text in options.outputs),
                              options.use_log_time, options.resample)
        with task_mapper(options.workers, options.dask) as mapper:
            outcome = tune_noises(bags, setup, structure, mapper, options.lags, options.burn_in,
                                  options.iterations, options.y_topic, options.u_topic,
                                  options.weighting, 'x_true' if options.report else None,
                                  choice)
        return (outcome, bags), summary(outcome, bags)

    def write_output(result, text):
        outcome, bags = result
        outcome.tuned.write(options.output, header=f'Tuned by tune_kalman from {len(bags)} '
                            f'bag(s); see its report.\n' + text)

    return run_tool('tune_kalman', options, compute, write_output, 'tuned parameters',
                    lambda result, text: write_report(options.report, *result, text),
                    lambda result: result[0].failed_checks, '--accept-failed-checks',
                    FAILED_CHECKS_STATUS)


if __name__ == '__main__':
    sys.exit(main())
