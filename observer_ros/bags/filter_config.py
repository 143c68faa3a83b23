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
The tuning tools' one window on the parameter schema: a Kalman filter's file, read and written.

Everything ``tune_kalman`` needs of a parameter file goes through :class:`KalmanSetup`:
the validated system (to replay), the model and the noise covariances by their argument
names, the sampled filter ALS models, and a new file with other noises, validated before it
is written. ``identify`` writes its model file through :func:`model_document`. Nothing else
in the tuning tools reads parameter names or the
:class:`~observer_ros.config.Configuration`.
"""

from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence

import numpy as np
import yaml

from observer_ros.app.run_report import write_atomically
from observer_ros.config import Configuration, load_parameter_file, validate_parameters
from observer_ros.core.errors import ConfigError
from observer_ros.core.observers.kalman import NAME as KALMAN_TYPE
from observer_ros.core.observers.kalman.design import KalmanDesign
from observer_ros.core.observers.kalman.estimator import KalmanStep
from observer_ros.core.tuning.noise_model import SampledFilter
from observer_ros.core.units import NANOSECONDS

#: The observer type whose noises the tools tune (its own name, from its package).
KALMAN = KALMAN_TYPE

#: Parameter names of the two covariances (``observer.<argument>``).
PROCESS_NOISE, MEASUREMENT_NOISE = 'observer.process_noise', 'observer.measurement_noise'


def _document(path) -> dict:
    try:
        with open(path, encoding='utf-8') as stream:
            document = yaml.safe_load(stream)
    except (OSError, yaml.YAMLError) as e:
        raise ConfigError('', f'cannot read parameter file {path}: {e}') from e
    return document


def system_of(parameters: dict) -> Configuration:
    """Return the validated system of a flat parameter mapping (unknown names refused)."""
    return validate_parameters(parameters, strict=True)


@dataclass(frozen=True)
class KalmanSetup:
    """
    A Kalman filter's parameter file, validated, with what tuning needs of it.

    Attributes
    ----------
    path : str
        The file it was read from.
    document : dict
        The YAML document as read (written back with new noises).
    parameters : dict
        The flat parameters as given (``model.A`` ...), picklable for worker processes.
    system : Configuration

    """

    path: str
    document: dict
    parameters: dict
    system: Configuration

    @property
    def model(self):
        """Return the :class:`~observer_ros.core.model.StateSpaceModel`."""
        return self.system.model

    @property
    def state_names(self) -> list:
        """Return the state names."""
        return list(self.system.model.state_names)

    @property
    def output_names(self) -> list:
        """Return the output names."""
        return list(self.system.model.output_names)

    @property
    def max_gap_ns(self) -> int:
        """``observer.max_gap`` in nanoseconds: a longer gap restarts the filter."""
        return self.system.observer.max_gap_ns

    @property
    def process_noise(self) -> np.ndarray:
        """``Q`` as configured, ``(n, n)`` (an intensity for a continuous model)."""
        return self.system.observer.design.process_noise

    @property
    def measurement_noise(self) -> np.ndarray:
        """``R`` as configured, ``(p, p)``."""
        return self.system.observer.design.measurement_noise

    def sampled_filter(self, period_ns: int) -> SampledFilter:
        """Return the steady-state filter over one period as ALS models it."""
        model = self.model
        step = KalmanStep(self.system.observer.design).step(int(period_ns))
        n_states, n_inputs = model.n_states, model.n_inputs
        gain = step.g[:n_states, n_states + n_inputs:]
        return SampledFilter(step.ad, model.c, gain, period_ns / NANOSECONDS,
                             None if model.is_discrete else model.a)

    def innovation_covariance(self, period_ns: int) -> np.ndarray:
        """``S = C P C^T + R`` of the steady-state filter over one period, ``(p, p)``."""
        return KalmanStep(self.system.observer.design).step(int(period_ns)).innovation_covariance

    def with_noises(self, process_noise, measurement_noise,
                    diagonal_process: bool = False,
                    diagonal_measurement: bool = False) -> 'KalmanSetup':
        """
        Return the setup with other ``Q`` and ``R`` (validated; the file is not written).

        ``diagonal_*`` writes the diagonal alone (n values) when the matrix is diagonal.
        """
        values = {PROCESS_NOISE: _flat(process_noise, diagonal_process),
                  MEASUREMENT_NOISE: _flat(measurement_noise, diagonal_measurement)}
        document = _with_values(self.document, values)
        parameters = dict(self.parameters, **values)
        return KalmanSetup(self.path, document, parameters, system_of(parameters))

    def write(self, path, header: str = '') -> Path:
        """
        Write the document to ``path`` (``header`` as comment lines first), all or nothing.

        The file is written under a temporary name, read back and validated, then renamed
        into place.
        """
        target = Path(path)
        text = ''.join(f'# {line}\n'.replace('# \n', '#\n') for line in header.splitlines())
        text += yaml.safe_dump(self.document, sort_keys=False, default_flow_style=None,
                               width=99)
        return write_validated(target, text)


def write_validated(target: Path, text: str) -> Path:
    """Write a parameter file under a temporary name, validate it, rename it into place."""
    return write_atomically(target, text, lambda scratch: validate_parameters(
        load_parameter_file(scratch), strict=True))


def _flat(matrix, diagonal: bool) -> list:
    matrix = np.asarray(matrix, dtype=float)
    if diagonal and not np.any(matrix - np.diag(np.diag(matrix))):
        return [float(v) for v in np.diag(matrix)]
    return [float(v) for v in matrix.ravel()]


def _with_values(document: dict, values: dict) -> dict:
    """Return a copy of ``document`` with ``values`` (dotted names) set where they live."""
    import copy
    document = copy.deepcopy(document)
    sections = [body['ros__parameters'] for body in document.values()
                if isinstance(body, dict) and isinstance(body.get('ros__parameters'), dict)]
    for name, value in values.items():
        path = name.split('.')
        placed = False
        for section in sections:
            holder = section
            for key in path[:-1]:
                holder = holder.get(key) if isinstance(holder, dict) else None
            if isinstance(holder, dict) and path[-1] in holder:
                holder[path[-1]] = value
                placed = True
        if not placed:
            holder = sections[0]
            for key in path[:-1]:
                holder = holder.setdefault(key, {})
            holder[path[-1]] = value
    return document


def load_kalman_setup(path) -> KalmanSetup:
    """
    Read and validate a Kalman filter's parameter file.

    Raises
    ------
    ConfigError
        A bad file (naming the parameter), an observer other than a Kalman filter
        (``observer.type``), or a model with disturbance states (``model.disturbances``).

    """
    parameters = load_parameter_file(str(path))
    system = system_of(parameters)
    if system.observer is None or not isinstance(system.observer.design, KalmanDesign):
        raise ConfigError('observer.type', f'tune_kalman tunes a Kalman filter: expected '
                          f'observer.type kalman with its noises, got '
                          f'{system.parameters.get("observer.type")!r}')
    if system.augmentation.disturbance is not None:
        raise ConfigError('model.disturbances', 'tune_kalman does not tune the noises of '
                          'disturbance states; remove model.disturbances to tune the plant')
    if system.observer.sources is not None:
        raise ConfigError('observer.sources', 'tune_kalman tunes a filter updated with every '
                          'output at each sample (one y topic); with measurement sources an '
                          'update sees only some outputs and the autocovariances of the '
                          'innovations do not follow one model: remove observer.sources and '
                          'give the outputs with tune_kalman --outputs TOPIC:PATH[,PATH...] '
                          '(several topics when stamped together, or resampled onto one grid '
                          'with --resample), or tune the measurement_noise of each source '
                          'from its own recording')
    return KalmanSetup(str(path), _document(path), parameters, system)


def model_document(a, b, c, d, dt: float, state_names: Sequence[str],
                   input_names: Sequence[str], output_names: Sequence[str],
                   measurement_noise, process_noise, topics: Optional[dict] = None) -> dict:
    """
    Return a parameter document of an identified model with a Kalman filter to start from.

    ``topics`` maps a role (``y``, ``u``) to ``{'type': ..., 'field': ...}``.
    """
    model = {'A': _flat(a, False), 'B': _flat(b, False), 'C': _flat(c, False),
             'D': _flat(d, False), 'dt': float(dt), 'state_names': list(state_names),
             'input_names': list(input_names), 'output_names': list(output_names)}
    section = {'model': model,
               'observer': {'type': KALMAN, 'process_noise': _flat(process_noise, True),
                            'measurement_noise': _flat(measurement_noise, False)}}
    if topics:
        section['topics'] = topics
    return {'/**': {'ros__parameters': section}}


__all__ = ['KALMAN', 'KalmanSetup', 'load_kalman_setup', 'model_document', 'system_of',
           'write_validated']
