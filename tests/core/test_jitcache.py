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

"""A kernel called with constants compiles once per argument type (rbd_ros.core.jitcache)."""

import numba
from rbd_ros.core import jitcache


def _scaled(flag, phase, x):
    if flag:
        return x * phase
    return x - phase


def _caller(callee):
    @numba.njit
    def caller(x):
        return callee(True, 0, x) + callee(False, 1, x) + callee(True, 2, x)
    return caller


def test_constants_do_not_add_specialisations():
    callee = jitcache._once_per_type(numba.njit(_scaled))
    assert _caller(callee)(3.0) == 3.0 * 0 + (3.0 - 1) + 3.0 * 2  # each value still taken
    assert len(callee.signatures) == 1, callee.signatures


def test_without_it_numba_compiles_once_per_constant():
    """The control: what the rule prevents (three calls, three literal signatures)."""
    callee = numba.njit(_scaled)
    _caller(callee)(3.0)
    assert len(callee.signatures) == 3, callee.signatures


def test_every_kernel_gets_the_rule():
    kernel = jitcache.kernel()(_scaled)
    assert kernel.get_call_template.__qualname__.startswith('_once_per_type')
