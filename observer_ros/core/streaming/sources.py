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

"""Several measurement sources in a stream: what the estimator can take of them."""

from typing import Optional, Sequence

from observer_ros.core.errors import ConfigError
from observer_ros.core.estimators import SubsetUpdates
from observer_ros.core.sources import check_subsets


class SourceUpdates:
    """Which outputs each row of several sources updates the estimator with."""

    def _check_sources(self, sources: tuple, output_names: Optional[Sequence[str]]) -> None:
        """Refuse what the estimator cannot do with these sources (at start-up)."""
        if self.form != 'current':
            raise ConfigError('form', 'the delayed form takes one measurement source without '
                              'a history; expected current with several sources or a history')
        partial = len(sources) > 1
        if partial:
            estimator = self.estimator
            problem = (estimator.several_sources_problem()
                       if isinstance(estimator, SubsetUpdates) else
                       f'this estimator ({type(estimator).__name__}) updates with every output '
                       f'at once')
            if problem is not None:
                raise ConfigError('sources', f'{problem}; got {len(sources)} sources '
                                  f'{[source.name for source in sources]}')
            self._updates = check_subsets(self.estimator, sources, output_names)
        self._owners = {index: source for source in sources for index in source.outputs}

    def _update_outputs(self, outputs: tuple) -> tuple:
        """Return the outputs to update with when ``outputs`` came: them, or none (predict)."""
        problem = self.estimator.subset_problem(outputs)
        owners = {self._owners[index] for index in outputs}
        if problem is None:
            update = outputs
        elif all(source.predict_only for source in owners):
            update = ()
        else:  # check_subsets refused this at start-up; say so if it comes anyway
            names = sorted(source.name for source in owners)
            raise ConfigError('sources', f'sources {names} together: {problem}')
        self._updates[outputs] = update
        return update
