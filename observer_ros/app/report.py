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

"""Design summaries: a JSON-ready dict and a MATLAB-session-like text report."""

import numpy as np

from observer_ros.config import Configuration
from observer_ros.core.errors import DesignError
from observer_ros.core.loop_analysis.diophantine import diophantine_controller
from observer_ros.core.loop_analysis.transfer_function import polynomial_text
from observer_ros.core.model import model_feedthrough
from observer_ros.core.poles import pole_pairs
from observer_ros.core.ranks import controllability, observability


def _rows(matrix) -> list:
    return np.atleast_2d(np.asarray(matrix, dtype=float)).tolist()


def _diophantine(system: Configuration):
    model, observer, feedback = system.model, system.observer, system.feedback
    if observer is None or feedback is None or system.loop.controller_tf is None:
        return None
    try:
        return diophantine_controller(model, feedback.design.requested_poles,
                                      observer.design.requested_poles)
    except DesignError:
        return None


def _sampled_step(system: Configuration):
    """Runtime step matrices at the plant rate (constant-G estimators of continuous models)."""
    if system.observer is None:
        return None
    estimator = system.observer.make_estimator()
    design = getattr(estimator, 'design', None)
    return None if design is None else design.step(system.plant.period_ns)


def _target(system: Configuration, disturbance) -> str:
    plant = system.augmentation.plant
    if disturbance.entry == 'input':
        return f'input {plant.input_names[disturbance.index]}'
    if disturbance.entry == 'output':
        return f'output {plant.output_names[disturbance.index]}'
    return f'column {disturbance.index} of model.disturbance_matrix'


def _disturbance_rows(system: Configuration) -> list:
    """Return one JSON row per disturbance: waveform (as ``kind``), entry, states, modes."""
    transform = system.augmentation.disturbance
    if transform is None:
        return []
    rows = []
    model = system.model
    for disturbance in transform.disturbances:
        block = slice(disturbance.first_state, disturbance.first_state + disturbance.n_states)
        rows.append({'name': disturbance.name, 'kind': disturbance.waveform,
                     'entry': _target(system, disturbance),
                     'frequency': disturbance.frequency,
                     'states': list(disturbance.state_names),
                     'state_indices': list(range(block.start, block.stop)),
                     'modes': pole_pairs(np.linalg.eigvals(model.a[block, block]))})
    return rows


def _slowest(system: Configuration):
    """Return the slowest achieved observer pole (the disturbance estimates' rate)."""
    poles = np.asarray(system.observer.design.achieved_poles, dtype=complex)
    if system.model.is_discrete:
        return poles[np.argmax(np.abs(poles))]
    return poles[np.argmax(poles.real)]


def _type_items(system: Configuration) -> tuple:
    """Return the observer type's own report fields (``ReportItem`` of each)."""
    return tuple(system.observer.kind.report(system.observer.design))


def design_summary(system: Configuration) -> dict:
    """
    Summarize a validated system as plain JSON types.

    Keys: ``model`` (n, m, p, dt, observability and controllability, ``feedthrough``
    when ``D`` is not zero), ``observer.*``
    (type, gain rows, requested and achieved poles as ``[re, im]``, method, residual, and
    the type's matrices), ``feedback.*`` when present, ``closed_loop_poles``,
    ``controller_tf`` (``num``/``den`` highest power first, ``den`` monic) and its
    Diophantine cross-check, ``sampled`` (the runtime step at ``plant.rate_hz``) and
    ``notes``.
    """
    model = system.model
    obs = observability(model.a, model.c)
    ctrb = controllability(model.a, model.b)
    summary = {
        'model': {
            'n_states': model.n_states, 'n_inputs': model.n_inputs,
            'n_outputs': model.n_outputs, 'dt': model.dt,
            'observable': obs.full_rank, 'observability_rank': obs.rank,
            'observability_condition': obs.condition_number,
            'unobservable_modes': pole_pairs(obs.lost_modes),
            'controllable': ctrb.full_rank, 'controllability_rank': ctrb.rank,
            'controllability_condition': ctrb.condition_number,
            'uncontrollable_modes': pole_pairs(ctrb.lost_modes),
        },
        'notes': list(system.loop.notes),
    }
    if model_feedthrough(model) is not None:
        summary['model']['feedthrough'] = _rows(model.d)
    disturbed = system.augmentation.disturbance is not None
    if disturbed:
        summary['model']['plant_states'] = system.augmentation.plant.n_states
        summary['disturbances'] = _disturbance_rows(system)
    observer = None if system.observer is None else system.observer.design
    if observer is not None:
        summary['observer.type'] = observer.kind
        summary['observer.gain'] = _rows(observer.gain)
        summary['observer.poles'] = pole_pairs(observer.achieved_poles)
        summary['observer.requested_poles'] = pole_pairs(observer.requested_poles)
        summary['observer.method'] = observer.method
        summary['observer.residual'] = observer.residual
        summary['observer.order'] = observer.order
        if disturbed:
            summary['observer.slowest_pole'] = pole_pairs([_slowest(system)])[0]
        for item in _type_items(system):
            summary[f'observer.{item.key}'] = (item.value if np.ndim(item.value) == 0
                                               else _rows(item.value))
        step = _sampled_step(system)
        if step is not None and not model.is_discrete:
            summary['sampled'] = {
                'rate_hz': system.plant.rate_hz,
                'poles': pole_pairs(step.poles),
                'step_matrix': _rows(step.g),
            }
    feedback = system.feedback
    if feedback is not None:
        summary['feedback.gain'] = _rows(feedback.design.gain)
        summary['feedback.poles'] = pole_pairs(feedback.design.achieved_poles)
        summary['feedback.method'] = feedback.design.method
        summary['feedback.residual'] = feedback.design.residual
        summary['feedback.reference_gain'] = (None if feedback.reference_gain is None
                                              else _rows(feedback.reference_gain))
        if feedback.disturbance_gain is not None:
            summary['feedback.disturbance_gain'] = _rows(feedback.disturbance_gain)
        if feedback.integral is not None:
            summary['feedback.integral_gain'] = _rows(feedback.integral.integral_gain)
            summary['feedback.integral_outputs'] = [
                system.model.output_names[i] for i in feedback.integral.outputs]
    if system.loop.closed_loop_poles is not None:
        summary['closed_loop_poles'] = pole_pairs(system.loop.closed_loop_poles)
    tf = system.loop.controller_tf
    if tf is not None:
        summary['controller_tf'] = {
            'num': tf.num.tolist(), 'den': tf.den.tolist(), 'zeros': pole_pairs(tf.zeros),
            'poles': pole_pairs(tf.poles), 'gain': tf.gain, 'unstable': tf.unstable,
        }
        check = _diophantine(system)
        if check is not None:
            summary['controller_tf_diophantine'] = {'num': check.num.tolist(),
                                                    'den': check.den.tolist()}
    return summary


def _matrix_text(name: str, matrix) -> str:
    matrix = np.atleast_2d(np.asarray(matrix, dtype=float))
    if not matrix.size:
        return f'{name} = (empty: {matrix.shape[0]} x {matrix.shape[1]})\n'
    body = '\n'.join('    ' + '  '.join(f'{value:12.6g}' for value in row) for row in matrix)
    return f'{name} =\n{body}\n'


def _poles_text(poles) -> str:
    def one(pole):
        if pole.imag == 0:
            return f'{pole.real:.6g}'
        return f'{pole.real:.6g}{pole.imag:+.6g}j'
    return '[' + ', '.join(one(complex(p)) for p in poles) + ']'


def format_report(system: Configuration) -> str:
    """Text report in the spirit of the seeds' MATLAB sessions."""
    model = system.model
    out = []
    kind = 'discrete (dt = %g s)' % model.dt if model.is_discrete else 'continuous'
    out.append(f'Model: n = {model.n_states}, m = {model.n_inputs}, '
               f'p = {model.n_outputs}, {kind}\n')
    obs = observability(model.a, model.c)
    out.append(f'Observability matrix: rank {obs.rank} of {obs.n_states}, '
               f'condition {obs.condition_number:.4g}\n')
    if model_feedthrough(model) is not None:
        out.append(_matrix_text('Feedthrough D (y = C x + D u: D u is taken off each '
                                'measurement with the input in effect at its stamp)', model.d))
    disturbed = system.augmentation.disturbance is not None
    if disturbed:
        n_plant = system.augmentation.plant.n_states
        count = model.n_states - n_plant
        out.append(f'Disturbances: {count} state{"s" if count > 1 else ""} after the '
                   f'{n_plant} plant states\n')
        for row in _disturbance_rows(system):
            frequency = f' {row["frequency"]:g} rad/s' if row['kind'] == 'sinusoid' else ''
            modes = _poles_text(complex(*pair) for pair in row['modes'])
            out.append(f'  {row["name"]}: {row["kind"]}{frequency} at {row["entry"]}, '
                       f'states {", ".join(row["states"])} (x_hat entries '
                       f'{", ".join(str(i) for i in row["state_indices"])}), generator '
                       f'modes {modes}\n')
    observer = None if system.observer is None else system.observer.design
    if observer is not None:
        out.append(f'\nObserver: {observer.kind} (order {observer.order}), '
                   f'method {observer.method}\n')
        out.append(_matrix_text('L', observer.gain))
        out.append(f'requested poles = {_poles_text(observer.requested_poles)}\n')
        out.append(f'achieved poles  = {_poles_text(observer.achieved_poles)}\n')
        out.append(f'residual = {observer.residual:.3g}\n')
        if disturbed:
            out.append(f'disturbance estimates converge like the slowest observer pole '
                       f'{_poles_text([_slowest(system)])}\n')
        for item in _type_items(system):
            if np.ndim(item.value) == 0:
                out.append(f'{item.label} = {item.value:.4g}\n')
            else:
                out.append(_matrix_text(item.label, item.value))
        step = _sampled_step(system)
        if step is not None and not model.is_discrete:
            out.append(f'sampled at {system.plant.rate_hz:g} Hz: discrete poles '
                       f'{_poles_text(step.poles)}\n')
    feedback = system.feedback
    if feedback is not None:
        out.append(f'\nState feedback (method {feedback.design.method})\n')
        out.append(_matrix_text('K', feedback.design.gain))
        if feedback.integral is not None:
            integral = feedback.integral
            names = [system.model.output_names[i] for i in integral.outputs]
            out.append(_matrix_text(f'K_i (integral action on {", ".join(names)})',
                                    integral.integral_gain))
            augmented = '[A 0; -T C_i I]' if system.model.is_discrete else '[A 0; -C_i 0]'
            out.append(f'poles of the augmented loop {augmented} = '
                       f'{_poles_text(integral.achieved_poles)}\n')
        else:
            out.append(f'poles of A - B K = {_poles_text(feedback.design.achieved_poles)}\n')
        if feedback.reference_gain is not None:
            out.append(_matrix_text('N (reference gain)', feedback.reference_gain))
        if feedback.disturbance_gain is not None and feedback.disturbance_gain.any():
            out.append(_matrix_text('K_d (disturbance rejection, u = -K x_hat - K_d d_hat)',
                                    feedback.disturbance_gain))
    if system.loop.closed_loop_poles is not None:
        out.append(f'\nClosed-loop poles = {_poles_text(system.loop.closed_loop_poles)}\n')
    tf = system.loop.controller_tf
    if tf is not None:
        variable = 'z' if model.is_discrete else 's'
        out.append('\nObserver-controller G_oc = -U/Y:\n')
        out.append(f'    {polynomial_text(tf.num, variable)}\n')
        out.append(f'    {"-" * 40}\n')
        out.append(f'    {polynomial_text(tf.den, variable)}\n')
        out.append(f'  zpk: {tf.format_zpk(variable)}\n')
        check = _diophantine(system)
        if check is not None:
            out.append(f'  Diophantine A R + B S = Acl: {check.format_polynomials(variable)}\n')
    for note in system.loop.notes:
        out.append(f'\nwarning: {note}\n')
    return ''.join(out)
