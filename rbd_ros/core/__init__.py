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
The physics core: rigid body dynamics, numpy and compiled kernels. Imports only itself.

Conventions: SI units; ``_w`` world and ``_b`` body coordinates; quaternions ``(w, x, y, z)``
with ``v_w = R(q_wb) v_b``; angular velocity stored in body coordinates; time in integer
nanoseconds. See :mod:`rbd_ros.core.integrators` for the integrators and what they conserve.
"""

from rbd_ros.core.errors import (ConfigError, ConvergenceError, InputError, ModelError,
                                 NonFiniteError, RbdError, RecordingError)
from rbd_ros.core.integrators import DEFAULT_INTEGRATOR, integrator_info, INTEGRATORS
from rbd_ros.core.loads import AppliedWrench, Spring
from rbd_ros.core.model import BodyModel
from rbd_ros.core.simulator import (accelerations, BatchSimulator, net_wrench_w, Simulator,
                                    step)
from rbd_ros.core.state import BodyState

__all__ = [
    'AppliedWrench', 'BatchSimulator', 'BodyModel', 'BodyState', 'ConfigError',
    'ConvergenceError', 'DEFAULT_INTEGRATOR', 'INTEGRATORS', 'InputError', 'ModelError',
    'NonFiniteError', 'RbdError', 'RecordingError', 'Simulator', 'Spring', 'accelerations',
    'integrator_info', 'net_wrench_w', 'step',
]
