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

"""Independent numpy references for the loads the core sums (written from their docstrings)."""

import numpy as np


def spring_force_w(spring, p, rot, v, omega_w):
    """
    Return ``(f, r)``: the spring's force on the body (N, world) and its lever ``r = R point_b``.

    ``d = p + r − anchor``, ``ẋ = v + ω_w × r``; with a rest length ``L > 0``
    ``f = −(k (|d| − L) + c ẋ·n) n``, ``n = d / |d|``, else ``f = −k d − c ẋ``.
    """
    r = rot @ spring.point_b
    d = p + r - spring.anchor_w
    rate = v + np.cross(omega_w, r)
    k, c, rest = spring.stiffness_n_per_m, spring.damping_n_s_per_m, spring.rest_length_m
    if rest > 0.0:
        n = d / np.linalg.norm(d)
        return -(k * (np.linalg.norm(d) - rest) + c * (rate @ n)) * n, r
    return -k * d - c * rate, r
