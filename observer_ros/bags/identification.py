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
Models from recordings: subspace identification from bags, scored on held-out data.

:func:`identify_bags` reads and pairs every bag's inputs and outputs through a ``mapper``
(:func:`~observer_ros.bags.paired_signals.bag_signals`, one task per bag, resampled onto a
uniform grid when asked), keeps the last ``holdout`` of every record for validation,
identifies from the rest (:func:`observer_ros.core.tuning.subspace.identify_subspace`) and
scores the model on the held-out part.
"""

from dataclasses import dataclass
from typing import Callable, Optional, Sequence, Union

import numpy as np

from observer_ros.bags.paired_signals import bag_signals, BagSignals, resample_period
from observer_ros.bags.signals import PERIOD_TOLERANCE, SignalSpec
from observer_ros.bags.storage import BagError
from observer_ros.core.errors import ConfigError, DesignError
from observer_ros.core.tuning.identified_model import (
    fit_percent, Record, SubspaceModel, to_continuous, validate)
from observer_ros.core.tuning.subspace import identify_subspace

#: Default fraction of each record held out for validation.
HOLDOUT = 0.3


def _signals_task(task: tuple) -> BagSignals:
    return bag_signals(*task)


@dataclass(frozen=True)
class Identification:
    """An identification run: the model, its fit on the held-out data and what it used."""

    model: SubspaceModel
    continuous: Optional[tuple]  # (A, B) when asked for
    fit: np.ndarray
    validation: list  # (stamps, measured, simulated) per held-out record
    signals: list
    period_ns: int
    residual_covariance: np.ndarray
    estimation_samples: int
    validation_samples: int
    raw_fit: Optional[np.ndarray] = None  # resampled: the fit of the raw samples
    raw_fit_error: str = ''  # resampled: why the raw samples gave no fit


def _common_period(signals: Sequence[BagSignals]) -> int:
    periods = [item.period_ns for item in signals]
    period = int(np.median(periods))
    for item in signals:
        if abs(item.period_ns - period) > PERIOD_TOLERANCE * period:
            raise BagError(f'{item.bag}: sampled every {item.period_ns / 1e6:g} ms, the other '
                           f'bags every {period / 1e6:g} ms; identify from bags of one rate, '
                           f'or resample them onto one grid (--resample RATE in Hz)')
    return period


def _identify(signals: Sequence[BagSignals], order: int, holdout: float,
              horizon: Optional[int], feedthrough: str = 'fit') -> tuple:
    """Return ``(model, fit, validation, covariance, estimation, held out, period)``."""
    period = _common_period(signals)
    estimation, held_out = [], []
    for item in signals:
        for stamps, record in item.records():
            split = int(round(len(stamps) * (1 - holdout)))
            estimation.append(Record(record.inputs[:split], record.outputs[:split]))
            held_out.append((stamps[split:], Record(record.inputs[split:],
                                                    record.outputs[split:])))
    model = identify_subspace(estimation, order, period / 1e9, horizon,
                              signals[0].input_names, feedthrough)
    validation = []
    for stamps, record in held_out:
        if len(stamps) <= 2 * order:
            continue
        simulated, _ = validate(model, record)
        validation.append((stamps, record.outputs, simulated))
    if not validation:
        raise BagError('no held-out data long enough to validate on; record longer or raise '
                       '--holdout')
    measured = np.concatenate([v[1] for v in validation])
    simulated = np.concatenate([v[2] for v in validation])
    residuals = np.concatenate([
        record.outputs - model.simulate(record.inputs, x0)
        for record, x0 in zip(estimation, model.initial_states)])
    covariance = np.atleast_2d(np.cov(residuals.T))
    return (model, fit_percent(measured, simulated), validation, covariance,
            sum(len(r.inputs) for r in estimation), len(measured), period)


def identify_bags(bags: Sequence[str], inputs: Sequence[SignalSpec],
                  outputs: Sequence[SignalSpec], order: int, mapper: Callable,
                  holdout: float = HOLDOUT, horizon: Optional[int] = None,
                  continuous: bool = False, use_log_time: bool = False,
                  resample_rate: Union[None, str, float] = None,
                  feedthrough: str = 'fit') -> Identification:
    """
    Identify a model of ``order`` from the bags and score it on their held-out parts.

    With ``resample_rate`` (Hz, or ``'auto'``) every bag is resampled onto a uniform grid
    (:func:`~observer_ros.bags.paired_signals.resample`) and the raw samples, taken as evenly
    spaced at their median interval, are identified and scored too:
    :attr:`Identification.raw_fit`, to compare.
    ``feedthrough`` (``fit`` or ``zero``): ``D`` fitted, or fixed at zero
    (:func:`~observer_ros.core.tuning.subspace.identify_subspace`).

    Raises
    ------
    BagError, ConfigError, DesignError
        Unusable bags (naming the cause), too little data for the order and horizon, no
        excitation, a model with no continuous counterpart.

    """
    if not 0 < holdout < 1:
        raise ConfigError('--holdout', f'expected a fraction in (0, 1), got {holdout}')
    resample_period(resample_rate, 1)  # a bad rate fails before any bag is read
    signals = list(mapper(_signals_task, [(bag, tuple(inputs), tuple(outputs), use_log_time,
                                           resample_rate) for bag in bags], 'read'))
    first = signals[0]
    for item in signals[1:]:
        if (item.input_names, item.output_names) != (first.input_names, first.output_names):
            raise BagError(f'{item.bag}: holds inputs {list(item.input_names)} and outputs '
                           f'{list(item.output_names)}, {first.bag} holds '
                           f'{list(first.input_names)} and {list(first.output_names)}')
    model, fit, validation, covariance, estimated, held, period = _identify(
        signals, order, holdout, horizon, feedthrough)
    raw_fit, raw_error = None, ''
    if first.raw is not None:
        try:
            raw_fit = _identify([item.raw for item in signals], order, holdout, horizon,
                                feedthrough)[1]
        except (BagError, ConfigError, DesignError, ValueError) as e:
            raw_error = str(e)
    converted = to_continuous(model.a, model.b, period / 1e9) if continuous else None
    return Identification(model, converted, fit, validation, signals, period, covariance,
                          estimated, held, raw_fit, raw_error)


__all__ = ['HOLDOUT', 'Identification', 'SignalSpec', 'identify_bags']
