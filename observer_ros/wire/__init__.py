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
The wire codec: CDR bytes of the messages robots publish to and from numpy, without ROS.

The nodes read and write their topics with it (:mod:`observer_ros.ros.messages`), the bag
tools their recorded messages (:mod:`observer_ros.bags.storage`), the configuration checks
field paths against it; it imports no rclpy and nothing else of this package, so it sits
at the bottom of the tree beside :mod:`observer_ros.core`. One module per job:
:mod:`~.layouts` (the bytes: header, stamps, parsed layouts), :mod:`~.catalog` (the
message types and their field paths), :mod:`~.vectors` (JointState and Float64MultiArray
vectors), :mod:`~.fields` (any type by field path) and :mod:`~.angles` (derived
angles).
"""

from observer_ros.wire.angles import ANGLES, quaternion_angle
from observer_ros.wire.catalog import (
    field_names, FIELD_TYPES, find, FIXED_LAYOUTS, FLOAT64_MULTI_ARRAY, full_type_name,
    JOINT_STATE, JOINT_STATE_FIELDS, lookup, message_class, message_types,
    MessageClassError, MessageType, quaternions, register, TYPE_NAMES, unregister,
    vector_layout)
from observer_ros.wire.fields import (
    by_field_path, decode_fields, FieldReader, FieldWriter, topic_reader)
from observer_ros.wire.layouts import (
    DecodeError, FieldPathError, FixedLayout, HEADER, joint_order, JointStateLayout, Layout,
    MultiArrayLayout, ORIGIN, STAMP, VectorLayout)
from observer_ros.wire.vectors import (
    decode, Encoder, MessageReader, MessageWriter, parse_layout)

__all__ = ['ANGLES', 'DecodeError', 'Encoder', 'FIELD_TYPES', 'FIXED_LAYOUTS',
           'FLOAT64_MULTI_ARRAY', 'FieldPathError', 'FieldReader', 'FieldWriter', 'FixedLayout',
           'HEADER', 'JOINT_STATE', 'JOINT_STATE_FIELDS', 'JointStateLayout', 'Layout',
           'MessageClassError', 'MessageReader', 'MessageType', 'MessageWriter',
           'MultiArrayLayout', 'ORIGIN', 'STAMP', 'TYPE_NAMES', 'VectorLayout', 'by_field_path',
           'decode', 'decode_fields', 'field_names', 'find', 'full_type_name', 'joint_order',
           'lookup', 'message_class', 'message_types', 'parse_layout', 'quaternion_angle',
           'quaternions', 'register', 'topic_reader', 'unregister', 'vector_layout']
