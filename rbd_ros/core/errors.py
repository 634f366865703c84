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
The rbd_ros error family.

Every error names the offending parameter or field, its value and its unit, so a user can fix
the input from the message alone.  The node turns these into rejected parameters (exit status 2
at start-up) or counted, throttled warnings; it never swallows them.
"""


import numpy as np


def frozen_vector(value, name, unit, size=3, error=None):
    """
    Return ``value`` as a read-only float64 array of ``size`` finite numbers.

    :raises RbdError: (``error``, :class:`InputError` by default) naming ``name``, the value
        and ``unit`` when it is not ``size`` numbers or not finite.
    """
    error = InputError if error is None else error
    try:
        array = np.array(value, dtype=np.float64).reshape(size)
    except (TypeError, ValueError):
        raise error(f'{name}: expected {size} numbers in {unit}, got {value!r}') from None
    if not np.all(np.isfinite(array)):
        raise error(f'{name}: {array.tolist()} {unit} is not finite')
    array.flags.writeable = False
    return array


class RbdError(Exception):
    """Base class of every error rbd_ros raises on purpose."""


class ModelError(RbdError, ValueError):
    """A body model is invalid: mass, inertia, gravity, damping or a shape's dimensions."""


class ConfigError(RbdError, ValueError):
    """A configuration value (integrator name, time step, frame, topic, ...) is invalid."""


class InputError(RbdError, ValueError):
    """An applied load (force, torque, spring, application point) is invalid."""


class NonFiniteError(RbdError, FloatingPointError):
    """A step would have produced a non-finite state; the state stays at its last finite value."""


class ConvergenceError(NonFiniteError):
    """
    An implicit step's solve did not converge (step too large for the spin); step refused.

    A :class:`NonFiniteError` for every handler: the step is refused the same way and the
    state stays at its last finite value; the message names ``h|ω|`` and what to change.
    """


class RecordingError(RbdError, OSError):
    """A recording cannot be written or read (path exists, disk full, truncated, foreign bag)."""
