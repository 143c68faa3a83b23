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
``replay``: run the configured observer over a recorded bag, offline, and report.

``replay BAG... PARAMS [--output BAG] [--csv FILE] [--in-order FILE] [--report DIR]`` reads
``y`` and ``u`` with their recorded stamps, writes ``x_hat`` and the innovation (the CSV
says what made each row, and has the covariance where the filter has one; ``--in-order``
writes the estimates in stamp order after every late sample), and with ``--report``
compares them with ``x_true`` (or ``--truth TOPIC``): the per-state error table, a PNG and
``DIR/replay.html`` (estimates against the reference, innovations with their +-2 sigma band,
NIS with its chi-square band, innovation autocorrelation with its whiteness bounds).
Several bags (or folders of bags) are replayed in worker processes (``--workers``) or on a
Dask cluster (``--dask``), each printed and reported on its own; ``--output`` and ``--csv``
take one bag.
``--reference STATE=TOPIC:FIELD:JOINT`` (repeatable) prints the RMSE of one state against a
recorded JointState field, e.g. the velocity a robot's ``/joint_states`` carries. A model
without inputs (``model.B`` empty) reads no ``u`` topic.
Everything is checked (parameter file, output paths, topics, time bases, the truth) before
anything is written; an error prints one line, exits with status 2 and leaves nothing
behind.
"""

import argparse
from pathlib import Path
import sys
import time

import numpy as np

from observer_ros.app.parallel import add_worker_arguments, task_mapper
from observer_ros.app.plots import write_run_report
from observer_ros.app.run_report import filter_run_section, HtmlReport
from observer_ros.bags.collection import expand_bags
from observer_ros.bags.replay import load_system, replay_bag
from observer_ros.bags.replay_outputs import (
    check_outputs, COVARIANCE_COLUMNS, made_directories, remove_outputs, write_replay)
from observer_ros.bags.replay_results import reference_rmse, StateReference
from observer_ros.bags.storage import BagError, STORAGES
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.evaluation import align, settling_time
from observer_ros.core.tuning.innovations import InnovationStatistics, whiteness
from observer_ros.signals import stops_on_signal

REPORT_NAME = 'replay'

#: Lags of the innovation autocorrelation in the report.
REPORT_LAGS = 30


def report_section(report: HtmlReport, result, truth=None) -> None:
    """Add one replayed bag to the HTML report (:func:`filter_run_section`)."""
    model = result.system.model
    correlation, bound = None, 0.0
    # With measurement sources a row has the innovations of the outputs that arrived (NaN
    # for the others): the autocorrelation is of the rows that have every output.
    complete = result.innovations[np.all(np.isfinite(result.innovations), axis=1)] if len(
        result.innovations) else result.innovations
    if len(complete) > REPORT_LAGS:
        statistics = InnovationStatistics(REPORT_LAGS, model.n_outputs)
        statistics.add(complete)
        try:
            judged = whiteness(statistics)
            correlation, bound = judged.correlation, judged.bound
        except ConfigError:
            pass  # an output that never varies: no autocorrelation to show
    covariance = (None if result.innovation_covariances is None
                  else result.innovation_covariances[-1])
    filter_run_section(report, str(result.bag), result.stamps_ns, result.estimates,
                       result.innovations, covariance, result.nis, model.state_names,
                       model.output_names, correlation, bound,
                       None if truth is None else truth.stamps_ns,
                       None if truth is None else truth.values)


#: Options that mean something only beside another: ``(option, attribute, needed, needed's
#: attribute)``.
DEPENDENT_OPTIONS = (('--settle', 'settle', '--reference', 'reference'),
                     ('--truth', 'truth', '--report', 'report'),
                     ('--storage', 'storage', '--output', 'output'))


def refuse_covariance_option(options, result) -> None:
    """Refuse ``--covariance`` without a CSV to write or a covariance to write in it."""
    if options.covariance is None:
        return
    if not (options.csv or options.in_order):
        raise ConfigError('--covariance', 'it applies to --csv and --in-order only: expected '
                          'one of them with it, or no --covariance')
    if result.covariances is None and options.covariance != 'none':
        raise ConfigError('--covariance', f'the {result.system.observer.design.kind} '
                          f'observer has no covariance to write: expected no --covariance')


def refuse_meaningless_options(options, system) -> None:
    """
    Refuse an option that the configuration (or the other options) makes meaningless.

    Raises
    ------
    ConfigError
        Naming the option and why it would be ignored.

    """
    if options.y_topic is not None and system.observer.sources is not None:
        topics = ', '.join(f'{settings.name}: {settings.topic}'
                           for settings in system.observer.sources.settings)
        raise ConfigError('--y-topic', f'the measurements are read from the topics of '
                          f'observer.sources ({topics}; sources.<name>.topic): expected no '
                          f'--y-topic')
    if system.model.n_inputs == 0 and options.u_topic is not None:
        raise ConfigError('--u-topic', 'the model has no inputs (model.B is empty): '
                          'expected no input topic')
    for option, attribute, needed, needed_attribute in DEPENDENT_OPTIONS:
        if getattr(options, attribute) is not None and not getattr(options, needed_attribute):
            raise ConfigError(option, f'it applies to {needed} only: expected {needed} with '
                              f'it, or no {option}')


def print_warnings(result) -> None:
    """Print what the observer node would have warned of during the replay, on stderr."""
    for warning in result.warnings:
        print(f'replay: warning: {warning}', file=sys.stderr)


def _truth_or_none(result, topic: str):
    try:
        return result.truth(topic)
    except BagError:
        return None


def _replay_task(task: tuple) -> dict:
    """Replay one of several bags (a worker's task); return what is printed and reported."""
    bag, params, y_topic, u_topic, use_log_time, truth_topic = task
    started = time.perf_counter()
    result = replay_bag(bag, params, y_topic, u_topic, use_log_time)
    elapsed = time.perf_counter() - started
    truth = _truth_or_none(result, truth_topic) if truth_topic else None
    error = None
    if truth is not None:
        _, reference, estimate = align(truth.stamps_ns, truth.values, result.stamps_ns,
                                       result.estimates)
        estimate = result.system.observer.angles.states_near(estimate, reference)
        if len(reference):
            error = float(np.sqrt(np.mean(np.sum((reference - estimate) ** 2, axis=1))))
    result.system = None  # the worker's System stays there: the arrays go back
    return {'result': result, 'elapsed': elapsed, 'truth': truth, 'rmse': error}


def replay_many(options, bags, system) -> int:
    """Replay several bags through the task mapper; print one line each, one report."""
    for option, value in (('--output', options.output), ('--csv', options.csv),
                          ('--in-order', options.in_order), ('--reference', options.reference),
                          ('--covariance', options.covariance)):
        if value:
            raise ConfigError(option, f'{len(bags)} bags given: {option} takes one bag')
    if options.report:
        check_outputs(None, None, options.report)
    tasks = [(bag, options.params, options.y_topic or 'y', options.u_topic or 'u',
              options.use_log_time, options.truth if options.report else None) for bag in bags]
    with task_mapper(options.workers, options.dask) as mapper:
        done = mapper(_replay_task, tasks, 'replay')
    report = HtmlReport(f'replay: {len(bags)} bags, {system.observer.design.kind} observer')
    for item in done:
        result = item['result']
        result.system = system
        counters = ', '.join(f'{key} {value}' for key, value in sorted(result.counters.items()))
        reference = ('' if item['rmse'] is None else
                     f'; RMSE against {options.truth} {item["rmse"]:.6g}')
        print(f'{result.bag}: {len(result.outputs.values)} measurements into '
              f'{len(result.stamps_ns)} estimates in {item["elapsed"]:.3f} s; {counters}'
              f'{reference}')
        print_warnings(result)
        if options.report:
            report_section(report, result, item['truth'])
    if options.report:
        print(f'report: {report.write(Path(options.report) / f"{REPORT_NAME}.html")}')
    return 0


@stops_on_signal('replay')
def main(args=None) -> int:
    """Entry point of ``replay`` (also ``ros2 run observer_ros replay``)."""
    parser = argparse.ArgumentParser(
        prog='replay', description='Run the configured observer over a rosbag2 bag offline.')
    parser.add_argument('bags', nargs='+', metavar='BAG',
                        help='rosbag2 bag directory (MCAP or sqlite3), a storage file, or a '
                        'folder of bags (several: one line and one report section each)')
    parser.add_argument('params', help='parameter file (/**: ros__parameters:)')
    parser.add_argument('--y-topic', default=None,
                        help='measurement topic in the bag (default y; none with '
                        'observer.sources, whose topics are configured)')
    parser.add_argument('--u-topic', default=None,
                        help='input topic in the bag (default u; none for a model without '
                        'inputs)')
    parser.add_argument('--output', metavar='BAG', help='write x_hat and innovation to a new bag')
    parser.add_argument('--storage', choices=STORAGES, default=None,
                        help='storage of --output (default mcap)')
    parser.add_argument('--csv', metavar='FILE',
                        help='write a row per published estimate: stamp, event (what made '
                        'the row: a source, rerun, input, flush), x_hat, innovation and the '
                        'covariance columns')
    parser.add_argument('--in-order', metavar='FILE',
                        help='write the estimates in stamp order after every late sample '
                        '(the history re-run): stamp, the sources of its update, x_hat and '
                        'the covariance columns')
    parser.add_argument('--covariance', choices=COVARIANCE_COLUMNS, default=None,
                        help='covariance columns of --csv and --in-order where the filter '
                        'has a covariance (default diagonal: variance_<state>; full: '
                        'covariance_<row>_<column>, row-major)')
    parser.add_argument('--report', metavar='DIR',
                        help='error table and DIR/replay.png against the true state')
    parser.add_argument('--truth', default=None,
                        help='true-state topic for --report (default x_true)')
    parser.add_argument('--reference', action='append', default=[],
                        metavar='STATE=TOPIC:FIELD:JOINT',
                        help='print the RMSE of STATE against a JointState field of one joint, '
                        'e.g. q_dot=/joint_states:velocity:shoulder (repeatable)')
    parser.add_argument('--settle', type=float, default=None, metavar='SECONDS',
                        help='--reference: skip the first SECONDS of estimates (default: the '
                        'settling time of the observer poles)')
    parser.add_argument('--use-log-time', action='store_true',
                        help='stamp y and u (and the truth) with their log times instead of '
                        'their header stamps (streams stamped in different time bases)')
    add_worker_arguments(parser, 'replay')
    options = parser.parse_args(args)
    try:
        system = load_system(options.params)
        refuse_meaningless_options(options, system)
        truth_named = options.truth is not None
        options.truth = options.truth or 'x_true'
        bags = expand_bags(options.bags)
        if len(bags) > 1:
            return replay_many(options, bags, system)
        options.bag = bags[0]
    except (BagError, ConfigError, DesignError, ValueError, OSError) as e:
        print(f'replay: error: {e}', file=sys.stderr)
        return 2
    try:
        # Everything is checked (parameters, outputs, topics, truth) before anything is written.
        references = [StateReference.parse(text) for text in options.reference]
        check_outputs(options.output, options.csv, options.report, options.in_order)
        started = time.perf_counter()
        result = replay_bag(options.bag, system, options.y_topic or 'y',
                            options.u_topic or 'u', options.use_log_time)
        settle = (options.settle if options.settle is not None else
                  settling_time(system.observer.design.achieved_poles, system.model.dt))
        refuse_covariance_option(options, result)
        rmse = [(reference, *reference_rmse(result, reference, settle))
                for reference in references]
        elapsed = time.perf_counter() - started
        truth, untrue = None, None
        if options.report:
            try:
                truth = result.truth(options.truth)
            except BagError as e:
                if truth_named:  # asked for by name: it must be there
                    raise BagError(f'--report: {e}') from e
                # A robot's bag has no true state: the report shows the estimates, the
                # innovations and NIS without the error table.
                untrue = (f'--report: no {options.truth} in the bag (no true state): the '
                          f'report shows the estimates and the innovations, without errors; '
                          f'--truth TOPIC names a reference')
            if truth is not None and not len(align(truth.stamps_ns, truth.values,
                                                   result.stamps_ns, result.estimates)[0]):
                raise BagError(f'{options.bag}: --report: {options.truth} and the estimates '
                               f'share no stamp; nothing to compare')
    except (BagError, ConfigError, DesignError, ValueError) as e:
        print(f'replay: error: {e}', file=sys.stderr)
        return 2
    made = made_directories(options.output, options.csv, options.in_order,
                            options.report and Path(options.report) / REPORT_NAME)
    plot = options.report and Path(options.report) / f'{REPORT_NAME}.png'
    written = [] if plot is None or plot.exists() else [plot]
    try:
        write_replay(result, options.output, options.csv, options.storage or 'mcap',
                     in_order=options.in_order, covariance=options.covariance or 'diagonal')
        written += [Path(p) for p in (options.output, options.csv, options.in_order)
                    if p is not None]
        counters = ', '.join(f'{key} {value}' for key, value in sorted(result.counters.items()))
        print(f'replayed {len(result.outputs.values)} measurements into '
              f'{len(result.stamps_ns)} estimates in {elapsed:.3f} s '
              f'({len(result.outputs.values) / max(elapsed, 1e-9):,.0f} samples/s); {counters}')
        print_warnings(result)
        if untrue:
            print(f'replay: warning: {untrue}', file=sys.stderr)
        for reference, error, count in rmse:
            print(f'{reference.state}: RMSE {error:.6g} against {reference.topic} '
                  f'{reference.field} of {reference.joint} ({count} estimates, after '
                  f'{settle:g} s)')
        if options.report:
            if truth is not None:
                print(write_run_report(
                    options.report, REPORT_NAME, result.system, truth.stamps_ns,
                    truth.values, result.stamps_ns, result.estimates,
                    title=f'{result.system.observer.design.kind} observer, {options.bag}'))
            kind = result.system.observer.design.kind
            page = HtmlReport(f'replay: {kind} observer, {options.bag}')
            report_section(page, result, truth)
            html_path = page.write(Path(options.report) / f'{REPORT_NAME}.html')
            written.append(html_path)
            print(f'report: {html_path}')
    except (BagError, ConfigError, DesignError, ValueError, OSError) as e:
        remove_outputs(written, made)
        print(f'replay: error: {e}', file=sys.stderr)
        return 2
    return 0


if __name__ == '__main__':
    sys.exit(main())
