# Copyright 2026 The rbd_ros authors
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
Joints between two rigid bodies (or a body and the world), in maximal coordinates.

A joint is a value: its kind, the two bodies it connects (``parent`` may be ``None``, the
world), its frame in each body (``origin_*_b`` and ``axis_b``) and its limits. The articulated
step (:class:`ArticulatedSimulator`) treats each joint as constraint rows between two bodies.
May import :mod:`rbd_ros.core` helpers only.
"""

from rbd_ros.core.joints.model import (cone_angle, Joint, JOINT_KINDS, joint_position,
                                       joint_velocity, unwrap_angle)
from rbd_ros.core.joints.simulator import ArticulatedSimulator, PROJECTION_TOL, ROWS

__all__ = ['ArticulatedSimulator', 'Joint', 'JOINT_KINDS', 'PROJECTION_TOL', 'ROWS',
           'cone_angle', 'joint_position', 'joint_velocity', 'unwrap_angle']
