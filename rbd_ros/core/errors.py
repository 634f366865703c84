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


import math
import numbers
from typing import Optional

import numpy as np


def finite_vector(value, name: str, unit: str, size: int = 3, error: Optional[type] = None,
                  frozen: bool = True) -> np.ndarray:
    """
    Return ``value`` as a float64 array of ``size`` finite numbers (read-only if ``frozen``).

    The one vector validator of the core: models, states, loads and inertia use it.

    :raises RbdError: (``error``, :class:`InputError` by default) naming ``name``, the value
        and ``unit`` when it is not ``size`` numbers or not finite.
    """
    error = InputError if error is None else error
    try:
        array = np.array(value, dtype=np.float64).reshape(size)
    except (TypeError, ValueError):
        raise field_error(error, name, f'expected {size} numbers in {unit}, got {value!r}',
                          value, unit) from None
    if not np.all(np.isfinite(array)):
        raise field_error(error, name, f'{array.tolist()} {unit} must be finite', value, unit)
    if frozen:
        array.flags.writeable = False
    return array


def finite_scalar(value, name: str, unit: str, *, minimum: Optional[float] = None,
                  strict: bool = False, error: Optional[type] = None) -> float:
    """
    Return ``value`` as a float after checking it is a real number, finite and in range.

    The one scalar validator of the core. ``minimum`` (optional) is inclusive, or exclusive
    with ``strict``. Booleans are refused; numpy scalars and 0-d arrays are accepted.

    :raises RbdError: (``error``, :class:`InputError` by default) naming ``name``, the value,
        ``unit`` and the rule, e.g. ``mass_kg: -1.0 kg must be > 0``.
    """
    error = InputError if error is None else error
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        if not (isinstance(value, np.ndarray) and value.shape == ()
                and (np.issubdtype(value.dtype, np.floating)
                     or np.issubdtype(value.dtype, np.integer))):
            raise field_error(error, name, f'{value!r} is not a number in {unit}', value, unit)
    number = float(value)
    if not math.isfinite(number):
        raise field_error(error, name, f'{number!r} {unit} must be finite', value, unit)
    if minimum is not None and (number <= minimum if strict else number < minimum):
        raise field_error(error, name,
                          f'{number!r} {unit} must be {">" if strict else ">="} {minimum:g}',
                          value, unit)
    return number


def positive(value, name: str, unit: str, error: Optional[type] = None) -> float:
    """Return ``value`` as a float after checking it is finite and > 0 (see finite_scalar)."""
    return finite_scalar(value, name, unit, minimum=0.0, strict=True, error=error)


def non_negative(value, name: str, unit: str, error: Optional[type] = None) -> float:
    """Return ``value`` as a float after checking it is finite and >= 0 (see finite_scalar)."""
    return finite_scalar(value, name, unit, minimum=0.0, error=error)


def whole_number(value, name: str, unit: str, *, positive: bool = False,
                 error: Optional[type] = None) -> int:
    """
    Return ``value`` as an ``int`` after checking it is an integer (not a bool, not a float).

    :raises RbdError: (``error``, :class:`InputError` by default) naming ``name``, the value and
        ``unit``, also when ``positive`` and the value is not > 0.
    """
    error = InputError if error is None else error
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) \
            or (positive and value <= 0):
        rule = 'a positive integer' if positive else 'an integer'
        raise field_error(error, name, f'{value!r} {unit} must be {rule}', value, unit)
    return int(value)


class RbdError(Exception):
    """
    Base class of every error rbd_ros raises on purpose.

    Besides its one-line message, an error may carry what it is about, so that code which names
    it anew (the parameter layer saying ``parameter bodies.a.mass_kg`` for the core's
    ``mass_kg``) reads attributes instead of parsing text (:func:`field_error` makes one):

    :ivar field: the parameter or field the message names first, or None.
    :ivar value: the offending value as given, or None.
    :ivar unit: its unit ('' for none), or None.
    :ivar detail: the message after ``<field>: `` (the value and what is wrong), or None.
    :ivar rule: what is wrong, without the value (where the raiser says it apart), or None.
    """

    def __init__(self, message='', *, field=None, value=None, unit=None, detail=None,
                 rule=None):
        super().__init__(message)
        if detail is None and field is not None and message.startswith(f'{field}: '):
            detail = message[len(field) + 2:]
        self.field, self.value, self.unit, self.detail = field, value, unit, detail
        self.rule = rule

    def renamed(self, field: str) -> 'RbdError':
        """Return the same error naming ``field`` where it named :attr:`field`."""
        return type(self)(str(self).replace(self.field, field, 1), field=field,
                          value=self.value, unit=self.unit, detail=self.detail, rule=self.rule)


def field_error(error: type, field: str, detail: str, value=None, unit=None) -> RbdError:
    """Return ``error('<field>: <detail>')`` carrying its field, value, unit and detail."""
    return error(f'{field}: {detail}', field=field, value=value, unit=unit, detail=detail)


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
