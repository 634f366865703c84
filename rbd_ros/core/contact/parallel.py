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
The contact step on threads: groups of islands stepped as worlds of their own, then checked.

A world without joints is separable (:mod:`rbd_ros.core.contact.step`): bodies that never
come within the broad phase's reach of each other step to the same bits together or apart,
and the world's contact rows are the groups' rows in the order of the world's pairs
(``tests/core/contact/test_islands.py``).  :class:`ParallelStep` uses that:

1. **Parts.** The bodies' boxes (the broad phase's, grown by their motion over the call and
   :data:`PARTITION_SLACK_M`) are swept for overlaps; the connected groups, in the order of
   their first body, are dealt to ``threads`` parts, each to the part with the fewest bodies
   so far (the first such).  A part is a world of its own: its bodies in the world's order,
   its own shape table, warm start and response cache (body indices renumbered), which stay
   with it from call to call while the parts stand (:data:`REPARTITION_CALLS`).
2. **Step.** Each part's :func:`~rbd_ros.core.contact.step.world_step` runs on its own thread
   of a pool made once (the kernels release the GIL); the first part on the caller's.
3. **Check.** The step records each body's broad-phase boxes over the call (``Work.span``).
   If no box of one part overlapped a box of another, the serial step would have paired
   exactly the pairs the parts did, stage by stage, so every bit is the serial step's: the
   states and wrenches are written back, and the contact rows are merged in the serial order
   when read.  Otherwise (or if a part's step failed) everything goes back to where the call
   started and the call is stepped serially, and the next :data:`SERIAL_AFTER_MISS` calls too.
   Boxes of two parts within twice :data:`PARTITION_SLACK_M` of each other (not yet
   touching) make new parts at the next call, so groups closing in on each other are merged
   before they meet.

So the results never depend on the thread count or the parts: only the wall time does.
"""

from concurrent.futures import ThreadPoolExecutor
import weakref

import numpy as np

from rbd_ros.core.contact import rows as cs
from rbd_ros.core.contact.broad_phase import _sweep
from rbd_ros.core.contact.step import world_step
from rbd_ros.core.layout import N_STATE, S_POS, S_VEL

#: Extra reach (m) of each body's box when the parts are made: a gap narrower than twice this
#: keeps two groups in one part (a check that fails costs the call twice).
PARTITION_SLACK_M = 0.01
#: Calls between two partitions while every check passes (groups that split apart get
#: parts of their own again; a new partition costs ~1 ms for 1000 bodies). Bodies of two
#: parts that come within twice :data:`PARTITION_SLACK_M` of each other make new parts at
#: the next call.
REPARTITION_CALLS = 50
#: Calls stepped serially after a failed check (bodies of two parts came within reach).
SERIAL_AFTER_MISS = 10
#: Fewest bodies a world needs for parts (below, a thread's hand-off costs more than it saves).
PARALLEL_MIN_BODIES = 16


def _overlaps(lo, hi):
    """Return the pairs ``(P, 2)`` of the boxes ``lo``, ``hi`` (N, 3) that overlap."""
    order = np.argsort(lo[:, 0], kind='stable')
    pairs = np.empty((4 * lo.shape[0] + 16, 2), dtype=np.int64)
    count = _sweep(order, lo, hi, pairs)
    if count > pairs.shape[0]:
        pairs = np.empty((count, 2), dtype=np.int64)
        _sweep(order, lo, hi, pairs)
    return pairs[:count]


def _groups(n, pairs):
    """Return ``(count, label (n,))``: the connected groups of ``pairs``, numbered from 0."""
    root = list(range(n))

    def find(i):
        while root[i] != i:
            root[i] = root[root[i]]
            i = root[i]
        return i

    for a, b in pairs.tolist():
        ra, rb = find(a), find(b)
        if ra != rb:
            root[max(ra, rb)] = min(ra, rb)
    roots = np.array([find(i) for i in range(n)], dtype=np.int64)
    _, label = np.unique(roots, return_inverse=True)
    return int(label.max()) + 1 if n else 0, label.reshape(-1)


def _subset_table(geo, index, n):
    """Return the :class:`~rbd_ros.core.contact.rows.Shapes` of the bodies ``index`` (sorted)."""
    n_static = geo.kinds.shape[0] - n
    sel = np.concatenate([index, n + np.arange(n_static)])
    k = index.shape[0]

    def ragged(data, off):
        parts = [data[off[s]:off[s + 1]] for s in sel]
        new_off = np.concatenate([[0], np.cumsum([len(p) for p in parts])]).astype(np.int64)
        return np.ascontiguousarray(np.concatenate(parts)), new_off

    pts, pt_off = ragged(geo.pts, geo.pt_off)
    ppts, ppt_off = ragged(geo.ppts, geo.ppt_off)
    balls, ball_off = ragged(geo.balls, geo.ball_off)
    cell_of = np.concatenate([geo.cell_of[geo.pt_off[s]:geo.pt_off[s + 1]] for s in sel])
    sizes = np.prod(geo.grid_dim, axis=1)
    grids = [geo.grid_data[geo.grid_off[s]:geo.grid_off[s] + sizes[s]] for s in sel]
    grid_off = np.concatenate([[0], np.cumsum([g.size for g in grids])[:-1]]).astype(np.int64)
    # The pairs that never collide, keyed a m + b (m = bodies + statics) in the part's numbers.
    m, mk = n + n_static, k + n_static
    local = np.full(m, -1, dtype=np.int64)
    local[index] = np.arange(k)
    local[n:] = k + np.arange(n_static)
    a, b = geo.skip // m, geo.skip % m
    kept = (local[a] >= 0) & (local[b] >= 0)
    skip = np.sort(local[a[kept]] * mk + local[b[kept]])
    return cs.Shapes(
        kinds=geo.kinds[sel], sparams=np.ascontiguousarray(geo.sparams[sel]), pts=pts,
        pt_off=pt_off, ppts=ppts, ppt_off=ppt_off, pt_radius=geo.pt_radius[sel],
        bound_r=geo.bound_r[sel], grid_data=np.ascontiguousarray(np.concatenate(grids)),
        grid_off=grid_off, grid_dim=np.ascontiguousarray(geo.grid_dim[sel]), mu=geo.mu[sel],
        eps=geo.eps[sel], balls=balls, ball_off=ball_off, cell_of=cell_of, skip=skip)


def _renumber(values, where, mapping):
    """Map the body numbers ``values[where]`` (floats) through ``mapping`` (a function)."""
    values[where] = mapping(values[where].astype(np.int64)).astype(np.float64)


class _Part:
    """One part: its bodies (world indices, sorted) and its own tables and work arrays."""

    def __init__(self, index, geo, ws, n):
        self.index = index
        k = index.shape[0]
        self.n_world = n
        self.geo = tuple(_subset_table(geo, index, n))
        self.local = np.full(n, -1, dtype=np.int64)
        self.local[index] = np.arange(k)
        self.x = np.empty((N_STATE, k))
        self.t = np.empty(k, dtype=np.int64)
        self.wrench = np.zeros((k, 6))
        self.contacts = np.zeros((0, cs.N_CONTACT))
        self.ws = cs.Work(
            vel=np.zeros((k, 6)), inv_mass=np.zeros(k), inv_inertia_w=np.zeros((k, 3, 3)),
            rot=np.zeros((k, 3, 3)), pos_c=np.zeros((k, 3)), rot_c=np.zeros((k, 3, 3)),
            touched=np.zeros(k, dtype=np.bool_), responses=ws.responses[index],
            warm=np.ascontiguousarray(ws.warm[:, index]),
            warm_n=np.ascontiguousarray(ws.warm_n[:, index]),
            stats=np.zeros((3, cs.N_SOLVE_STATS)), span=np.empty((k, 6)))
        self._map(self.ws.responses, self.ws.warm, self.ws.warm_n, self._to_part)

    def _to_part(self, b):
        """World body numbers (N + s a static object) -> the part's (-3 - b: another part's)."""
        n, k = self.n_world, self.index.shape[0]
        local = self.local[np.clip(b, 0, n - 1)]
        return np.where(b >= n, b - n + k, np.where(local >= 0, local, -3 - b))

    def _to_world(self, b):
        n, k = self.n_world, self.index.shape[0]
        return np.where(b >= k, b - k + n,
                        np.where(b >= 0, self.index[np.clip(b, 0, k - 1)], -3 - b))

    @staticmethod
    def _map(responses, warm, warm_n, mapping):
        """Renumber the body numbers of a response cache and a warm start (only those set)."""
        _renumber(responses[:, cs.R_STATIC], responses[:, cs.R_STATIC] >= 0, mapping)
        held = np.arange(cs.W_SLOTS)[None, None, :] < warm_n[:, :, None]
        column = warm[..., cs.W_B]
        _renumber(column, held, mapping)
        warm[..., cs.W_B] = column

    def give_back(self, ws):
        """Write the part's response cache, warm start and counters into the world's ``ws``."""
        responses, warm, warm_n = (self.ws.responses.copy(), self.ws.warm.copy(),
                                   self.ws.warm_n.copy())
        self._map(responses, warm, warm_n, self._to_world)
        ws.responses[self.index] = responses
        ws.warm[:, self.index] = warm
        ws.warm_n[:, self.index] = warm_n
        ws.stats[:] += self.ws.stats
        self.ws.stats[:] = 0.0

    def world_contacts(self):
        """Return the part's contact rows of its last call in world body numbers."""
        c = self.contacts.copy()
        k = self.index.shape[0]
        c[:, cs.C_A] = self.index[c[:, cs.C_A].astype(np.int64)]
        b = c[:, cs.C_B].astype(np.int64)
        c[:, cs.C_B] = np.where(b >= k, b - k + self.n_world, self.index[np.clip(b, 0, k - 1)])
        return c


class ParallelStep:
    """
    The contact step of a :class:`~rbd_ros.core.contact.simulator.WorldSimulator` on threads.

    :param sim: the world (no joints), whose arrays this reads and writes.
    :param threads: the thread count >= 2.
    """

    def __init__(self, sim, threads):
        self._sim = sim
        self._threads = threads
        self._pool = None
        self._parts = None       # the parts, or None: the world's own arrays are current
        self._calls = 0          # calls since the parts were made
        self._serial = 0         # calls left to step serially
        self._merged = None      # the last call's contacts in the serial order, once merged
        self.calls_parallel = 0  # calls stepped in parts (checked)
        self.calls_serial = 0    # calls stepped serially (too few bodies or groups, a miss)
        self.misses = 0          # calls whose check failed (stepped again serially)

    def _pool_or_new(self):
        if self._pool is None:
            self._pool = ThreadPoolExecutor(self._threads - 1, thread_name_prefix='rbd_islands')
            weakref.finalize(self, self._pool.shutdown, wait=False)
        return self._pool

    def settle(self):
        """Give the parts' tables back to the world's arrays and drop the parts."""
        if self._parts is not None:
            sim = self._sim
            sim._contacts = self.contacts()
            for part in self._parts:
                part.give_back(sim._ws)
            self._parts = None

    def stats(self):
        """Return the world's solve counters (3, N_SOLVE_STATS), the parts' added."""
        stats = self._sim._ws.stats.copy()
        for part in self._parts or ():
            stats += part.ws.stats
        return stats

    def contacts(self):
        """Return the contact rows of the last call, in the serial order."""
        if self._parts is None:
            return self._sim._contacts
        if self._merged is None:
            c = np.concatenate([p.world_contacts() for p in self._parts])
            n = self._sim.size
            static = c[:, cs.C_B] >= n
            self._merged = c[np.lexsort((c[:, cs.C_B], c[:, cs.C_A], static, c[:, cs.C_PHASE]))]
        return self._merged

    def _partition(self, n_steps):
        """Make the parts (at least two), or return False when the world is one group."""
        sim = self._sim
        n = sim.size
        x = sim._x
        reach = (sim._geo.bound_r[:n] + cs.MARGIN_M + PARTITION_SLACK_M
                 + 2.0 * n_steps * sim._h * np.linalg.norm(x[S_VEL:S_VEL + 3], axis=0))
        centre = x[S_POS:S_POS + 3].T
        pairs = _overlaps(np.ascontiguousarray(centre - reach[:, None]),
                          np.ascontiguousarray(centre + reach[:, None]))
        count, label = _groups(n, pairs)
        if count < 2:
            return False
        # Groups in the order of their first body, each to the part with fewest bodies.
        first = np.full(count, n, dtype=np.int64)
        np.minimum.at(first, label, np.arange(n))
        sizes = np.bincount(label, minlength=count)
        bins = min(self._threads, count)
        load = np.zeros(bins, dtype=np.int64)
        part_of_group = np.empty(count, dtype=np.int64)
        for g in np.argsort(first, kind='stable'):
            p = int(np.argmin(load))
            part_of_group[g] = p
            load[p] += sizes[g]
        part_of = part_of_group[label]
        self._parts = [_Part(np.flatnonzero(part_of == p), sim._geo, sim._ws, n)
                       for p in range(bins)]
        self._calls = 0
        return True

    def step(self, n_steps):
        """
        Advance the world ``n_steps`` steps; return ``(steps done, contacts or None)``.

        ``contacts`` None: the contact rows are the parts' (:meth:`contacts` merges them).
        """
        sim = self._sim
        if self._serial > 0 or sim.size < PARALLEL_MIN_BODIES:
            self._serial = max(0, self._serial - 1)
            return self._serial_step(n_steps)
        if self._parts is not None and self._calls >= REPARTITION_CALLS:
            self.settle()
        if self._parts is None and not self._partition(n_steps):
            self._serial = REPARTITION_CALLS
            return self._serial_step(n_steps)
        self._calls += 1
        parts = self._parts
        shared = sim._params.shape[1] == 1
        saved = []
        for part in parts:
            ws = part.ws
            part.x[:] = sim._x[:, part.index]
            part.t[:] = sim._t[part.index]
            held = np.flatnonzero(ws.warm_n.any(axis=0))
            saved.append((ws.responses.copy(), held, ws.warm[:, held].copy(),
                          ws.warm_n.copy(), ws.stats.copy()))
            ws.span[:, :3] = np.inf
            ws.span[:, 3:] = -np.inf

        def run(part):
            prm = sim._params if shared else np.ascontiguousarray(sim._params[:, part.index])
            return world_step(part.x, prm, np.ascontiguousarray(sim._loads[part.index]), part.t,
                              sim._info.kernel_id, sim._h, sim._timestep_ns, n_steps,
                              part.geo, tuple(sim._statics), part.wrench, tuple(part.ws), None)

        futures = [self._pool_or_new().submit(run, part) for part in parts[1:]]
        results = [run(parts[0])] + [f.result() for f in futures]
        ok = all(done == n_steps for done, _ in results)
        if ok:
            span = np.empty((sim.size, 6))
            owner = np.empty(sim.size, dtype=np.int64)
            for p, part in enumerate(parts):
                span[part.index] = part.ws.span
                owner[part.index] = p
            lo, hi = span[:, :3], span[:, 3:]
            near = _overlaps(lo - PARTITION_SLACK_M, hi + PARTITION_SLACK_M)
            near = near[owner[near[:, 0]] != owner[near[:, 1]]]
            a, b = near[:, 0], near[:, 1]
            ok = not np.any(np.all((lo[a] <= hi[b]) & (lo[b] <= hi[a]), axis=1))
            if near.shape[0] > 0:   # bodies of two parts within reach: new parts next call
                self._calls = REPARTITION_CALLS
        if not ok:   # back to the call's start; the serial step decides
            self.misses += 1
            for part, (responses, held, warm, warm_n, stats) in zip(parts, saved):
                part.ws.responses[:] = responses
                part.ws.warm[:, held] = warm
                part.ws.warm_n[:] = warm_n
                part.ws.stats[:] = stats
            self._merged = None
            for part in parts:
                part.contacts = np.zeros((0, cs.N_CONTACT))
            self.settle()
            self._serial = SERIAL_AFTER_MISS
            return self._serial_step(n_steps)
        for part, (_, contacts) in zip(parts, results):
            sim._x[:, part.index] = part.x
            sim._t[part.index] = part.t
            sim._wrench[part.index] = part.wrench
            part.contacts = contacts
        self._merged = None
        self.calls_parallel += 1
        return n_steps, None

    def _serial_step(self, n_steps):
        self.calls_serial += 1
        self.settle()
        sim = self._sim
        return world_step(sim._x, sim._params, sim._loads, sim._t, sim._info.kernel_id, sim._h,
                          sim._timestep_ns, n_steps, tuple(sim._geo), tuple(sim._statics),
                          sim._wrench, tuple(sim._ws), None)
