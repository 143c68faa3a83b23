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

"""An observer type outside observer_ros: registered in the entry-point group only."""

from setuptools import setup

setup(
    name='observer_ros_alpha_beta',
    version='0.1.0',
    packages=['observer_ros_alpha_beta'],
    description='An alpha-beta tracker with a clipped innovation, as an observer_ros type.',
    license='Apache-2.0',
    entry_points={
        'observer_ros.observer_types': [
            'alpha_beta = observer_ros_alpha_beta:TYPE',
        ],
    },
)
