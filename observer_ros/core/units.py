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
Units of the package: stamps are integer nanoseconds, durations in formulas seconds.

Examples
--------
>>> from observer_ros.core.units import NANOSECONDS
>>> 10_000_000 / NANOSECONDS
0.01

"""

#: Nanoseconds per second: a stamp ``t_ns`` is ``t_ns / NANOSECONDS`` seconds.
NANOSECONDS = 1_000_000_000

__all__ = ['NANOSECONDS']
