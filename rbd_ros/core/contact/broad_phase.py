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
Broad phase: the candidate pairs of a stage, in a fixed order.

Sort and sweep along x over the bodies' bounding balls; every body against each static
object's bounds.
"""

import numpy as np

from rbd_ros.core.contact import kernels as ck
from rbd_ros.core.contact.rows import _jit, _raw
from rbd_ros.core.layout import S_POS


@_raw
def _sweep(order, lo, hi, pairs):
    """
    Write the pairs whose boxes ``lo``, ``hi`` overlap into ``pairs``, swept in ``order``.

    Return how many overlap; only as many as ``pairs`` has rows are written.
    """
    n = order.shape[0]
    count = 0
    for oi in range(n):
        a = order[oi]
        for oj in range(oi + 1, n):
            b = order[oj]
            if lo[b, 0] > hi[a, 0]:
                break
            if (lo[b, 1] > hi[a, 1] or lo[a, 1] > hi[b, 1]
                    or lo[b, 2] > hi[a, 2] or lo[a, 2] > hi[b, 2]):
                continue
            if count < pairs.shape[0]:
                pairs[count, 0] = min(a, b)
                pairs[count, 1] = max(a, b)
            count += 1
    return count


@_jit
def broad_phase(x, pos_c, bound_r, n_bodies, st_kind, st_params, st_lo, st_hi, margin, skip,
                span):
    """
    Return the candidate pairs ``(P, 2)`` int64, in a fixed order.

    Body-body pairs ``(a, b)`` with ``a < b`` sorted, then body-static ``(a, N + s)``. A pair
    whose key ``a (N + S) + b`` is in ``skip`` (sorted int64, ``S`` the static objects: a body
    and a body or a static object that never collide, such as a robot's adjacent links) is
    left out.

    Each body's box holds its bounding ball at the current and the candidate pose, grown by
    ``margin``; bodies are sorted by the low x of their box and swept, so the cost is
    O(N log N + pairs).  ``span`` (N, 6) grows to hold each body's box (low then high corner).
    """
    n = n_bodies
    lo = np.empty((n, 3))
    hi = np.empty((n, 3))
    for i in range(n):
        r = bound_r[i] + margin
        for k in range(3):
            a = x[S_POS + k, i]
            b = pos_c[i, k]
            lo[i, k] = min(a, b) - r
            hi[i, k] = max(a, b) + r
            span[i, k] = min(span[i, k], lo[i, k])
            span[i, 3 + k] = max(span[i, 3 + k], hi[i, k])
    order = np.argsort(lo[:, 0], kind='mergesort')
    pairs = np.empty((4 * n + 16, 2), dtype=np.int64)
    count = _sweep(order, lo, hi, pairs)
    if count > pairs.shape[0]:  # more overlaps than room: sweep again with room for all
        pairs = np.empty((count, 2), dtype=np.int64)
        _sweep(order, lo, hi, pairs)
    body_pairs = pairs[:count]
    # Fixed processing order whatever the sort did with ties: by (a, b).
    m = n + st_kind.shape[0]
    key = body_pairs[:, 0] * m + body_pairs[:, 1]
    ranked = np.argsort(key, kind='mergesort')
    body_pairs = body_pairs[ranked]
    if skip.shape[0] > 0:
        kept = 0
        for p in range(body_pairs.shape[0]):
            k = key[ranked[p]]
            at = np.searchsorted(skip, k)
            if at < skip.shape[0] and skip[at] == k:
                continue
            body_pairs[kept, 0] = body_pairs[p, 0]
            body_pairs[kept, 1] = body_pairs[p, 1]
            kept += 1
        body_pairs = body_pairs[:kept]
    statics = np.empty((n * st_kind.shape[0], 2), dtype=np.int64)
    ns = 0
    for a in range(n):
        for s in range(st_kind.shape[0]):
            if st_kind[s] == ck.KIND_PLANE:
                nx, ny, nz, d = st_params[s, 0], st_params[s, 1], st_params[s, 2], st_params[s, 3]
                near = min(nx * x[S_POS, a] + ny * x[S_POS + 1, a] + nz * x[S_POS + 2, a],
                           nx * pos_c[a, 0] + ny * pos_c[a, 1] + nz * pos_c[a, 2]) - d
                if near > bound_r[a] + margin:
                    continue
            elif (lo[a, 0] > st_hi[s, 0] or st_lo[s, 0] > hi[a, 0]
                  or lo[a, 1] > st_hi[s, 1] or st_lo[s, 1] > hi[a, 1]
                  or lo[a, 2] > st_hi[s, 2] or st_lo[s, 2] > hi[a, 2]):
                continue
            if skip.shape[0] > 0:
                at = np.searchsorted(skip, a * m + n + s)
                if at < skip.shape[0] and skip[at] == a * m + n + s:
                    continue
            statics[ns, 0] = a
            statics[ns, 1] = n + s
            ns += 1
    out = np.empty((body_pairs.shape[0] + ns, 2), dtype=np.int64)
    out[:body_pairs.shape[0]] = body_pairs
    out[body_pairs.shape[0]:] = statics[:ns]
    return out


# ---------------------------------------------------------------------------------------------
# Narrow phase: points of one shape against the φ of the other, at the candidate poses.
