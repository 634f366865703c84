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
The simulators: the one mutable object of the core.

:class:`BatchSimulator` steps ``N`` independent bodies stored as a structure of arrays;
:class:`Simulator` is the single-body case (``N = 1``): the same class and the same compiled
kernel, so a body stepped alone and the same body stepped in a batch are bit-identical. Time is
integer nanoseconds and advances in fixed steps only.
"""

import os
import time
from typing import Iterable, Optional, Sequence, Tuple, Union

import numba
import numpy as np

from rbd_ros.core import jitcache, kernels, layout
from rbd_ros.core.errors import (ConfigError, ConvergenceError, InputError, NonFiniteError,
                                 whole_number)
from rbd_ros.core.integrators import DEFAULT_INTEGRATOR, integrator_info
from rbd_ros.core.loads import AppliedWrench, Spring
from rbd_ros.core.model import BodyModel
from rbd_ros.core.state import BodyState

# h|ω| (rad) below which the implicit midpoint solve of midpoint_cayley always converged in a
# sweep of 2000 random inertias and spin axes per value (first failure at 3 rad, 1.5 % at 4).
MIDPOINT_SAFE_ROTATION_RAD = 2.0

# Bodies per batch above which the threaded kernel pays for its start-up (measured on the
# 2-core machine: below ~2000 bodies the thread pool costs more than it saves). Each thread
# gets at least this many bodies.
PARALLEL_MIN_BODIES = 2048

# How often (wall seconds) the automatic thread count looks at the load again: the 1-minute
# load average moves slowly, and a second is many steps at the batch sizes that use threads.
THREADS_RECHECK_S = 1.0


def usable_cores() -> int:
    """Return the CPUs this process may run on (``threads``' default, the pools' size)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:   # not on Linux
        return os.cpu_count() or 1


def free_cores() -> int:
    """
    Return how many of this process's CPUs are not busy with other processes (at least 1).

    The CPUs this process may run on (``os.sched_getaffinity``) minus the 1-minute load average
    of the others (the load less the one runnable thread of this process, when it is stepping),
    rounded to the nearest whole core.
    """
    cores = usable_cores()
    try:
        others = max(0.0, os.getloadavg()[0] - 1.0)
    except OSError:
        others = 0.0
    return max(1, min(cores, int(cores - others + 0.5)))


def choose_threads(n_bodies: int, threads: Optional[int] = None) -> int:
    """
    Return the thread count for a batch step of ``n_bodies`` bodies.

    ``threads`` given: that many (at most numba's pool size, ``numba.config.NUMBA_NUM_THREADS``).
    Automatic (``None``): 1 below ``PARALLEL_MIN_BODIES`` bodies, else one thread per free core
    (:func:`free_cores`) and per ``PARALLEL_MIN_BODIES`` bodies, at most the pool size: a
    thread on a core another process holds makes the whole step wait for it (measured: 100 000
    bodies ran at 4.3 M body-steps/s on 2 threads with the other core busy, 8.3 M on 1).
    Results are bit-identical whatever the count: each body runs the same scalar code.
    """
    pool = numba.config.NUMBA_NUM_THREADS
    if threads is not None:
        return min(whole_number(threads, 'threads', 'threads', positive=True,
                                error=ConfigError), pool)
    if n_bodies < PARALLEL_MIN_BODIES:
        return 1
    return max(1, min(pool, free_cores(), n_bodies // PARALLEL_MIN_BODIES))


def _load_rows(wrenches, springs):
    """Pack loads into kernel rows (:mod:`rbd_ros.core.layout`)."""
    rows = np.zeros((len(wrenches) + len(springs), layout.N_LOAD))
    for row, wrench in zip(rows, wrenches):
        if not isinstance(wrench, AppliedWrench):
            raise InputError(f'wrenches: {wrench!r} is not an AppliedWrench')
        kind = layout.LOAD_WORLD if wrench.frame == 'world' else layout.LOAD_BODY
        layout.pack_wrench(row, kind, wrench.point_b, wrench.force, wrench.torque)
    for row, spring in zip(rows[len(wrenches):], springs):
        if not isinstance(spring, Spring):
            raise InputError(f'springs: {spring!r} is not a Spring')
        layout.pack_spring(row, spring.point_b, spring.anchor_w, spring.stiffness_n_per_m,
                           spring.damping_n_s_per_m, spring.rest_length_m)
    return rows


class BatchSimulator:
    """
    ``N`` independent rigid bodies, one integrator and one fixed step.

    :param models: one :class:`BodyModel` for all bodies, or a sequence of ``N``.
    :param states: a sequence of ``N`` :class:`BodyState` (their times must agree).
    :param integrator: a name from :data:`rbd_ros.core.integrators.INTEGRATORS`.
    :param timestep_ns: the fixed step ``h``, integer nanoseconds > 0.
    :param threads: threads per step; ``None`` (default) chooses by ``N`` and by the cores
        free at the time (:func:`choose_threads`, looked at again every
        ``THREADS_RECHECK_S``), an integer >= 1 fixes it. Results are bit-identical either way.
    """

    def __init__(self, models: Union[BodyModel, Sequence[BodyModel]],
                 states: Iterable[BodyState], *, integrator: str = DEFAULT_INTEGRATOR,
                 timestep_ns: int = 1_000_000, threads: Optional[int] = None):
        jitcache.configured()  # the kernel cache, before a first compile
        states = list(states)
        if not states:
            raise ConfigError('states: a batch needs at least one body')
        models = [models] * len(states) if isinstance(models, BodyModel) else list(models)
        if len(models) != len(states):
            raise ConfigError(
                f'models: {len(models)} models for {len(states)} states; give one or N')
        self._info = integrator_info(integrator)
        self._timestep_ns = whole_number(timestep_ns, 'timestep_ns', 'ns', positive=True,
                                         error=ConfigError)
        self._h = self._timestep_ns * 1e-9
        self._models = tuple(models)
        self._initial_states = tuple(states)
        # One shared parameter column when every body has the same model (less memory traffic).
        shared = all(m is models[0] or m == models[0] for m in models)
        self._params = np.ascontiguousarray(np.stack(
            [layout.pack_params(m) for m in (models[:1] if shared else models)], axis=1))
        self._x = np.empty((layout.N_STATE, len(states)))
        self._t = np.empty(len(states), dtype=np.int64)
        self._loads = np.zeros((len(states), 0, layout.N_LOAD))
        # Automatic threads only where they can pay (N >= PARALLEL_MIN_BODIES); a single body
        # pays nothing for the choice on its hot path.
        self._threads_auto = threads is None and len(states) >= PARALLEL_MIN_BODIES
        self._threads_checked = -float('inf')
        self._set_threads(1 if threads is None else choose_threads(len(states), threads))
        # One flag on the hot path: is there anything to do about threads before a step?
        self._threads_prepare = self._kernel is kernels.advance_parallel
        # Automatic threads: wall seconds per step of the last call on each candidate count.
        most = min(numba.config.NUMBA_NUM_THREADS, len(states) // PARALLEL_MIN_BODIES,
                   usable_cores())
        self._cost_s = {}
        if self._threads_auto:
            self._set_threads(choose_threads(len(states)))
            self._threads_checked = time.monotonic()
            self._candidates = (1, most) if most > 1 else (1,)
        self._step_count = 0
        self.reset()

    @property
    def threads(self) -> int:
        """Return the number of threads the next step uses."""
        return self._threads

    def _set_threads(self, threads):
        # Batches of PARALLEL_MIN_BODIES or more always run the batch kernel, on 1 thread too
        # (its per-body code is inlined: ~20 % faster with one step per call); smaller ones
        # the serial kernel unless more threads were asked for. Same numbers either way.
        self._threads = threads
        batch = threads > 1 or self.size >= PARALLEL_MIN_BODIES
        self._kernel = kernels.advance_parallel if batch else kernels.advance

    def _prepare_threads(self):
        """
        Choose the automatic thread count when due; tell numba the count to use.

        Automatic: the two candidates are 1 thread and one per core (:func:`choose_threads`
        with every core free); each step call is timed, and every ``THREADS_RECHECK_S`` one
        call runs on the other candidate, so the faster of the two as measured now is used.
        This sees a core taken by another process at once, where the 1-minute load average
        (:func:`free_cores`, the first choice) lags by a minute.
        """
        if self._threads_auto:
            now = time.monotonic()
            if now - self._threads_checked >= THREADS_RECHECK_S:
                self._threads_checked = now
                if len(self._cost_s) == 2:
                    # Try the other candidate for one call (its figure may be stale).
                    other = [k for k in self._cost_s if k != self._threads][0]
                    self._set_threads(other)
            elif len(self._cost_s) == 2:
                self._set_threads(min(self._cost_s, key=self._cost_s.get))
        numba.set_num_threads(self._threads)

    @property
    def size(self) -> int:
        """Return the number of bodies ``N``."""
        return self._x.shape[1]

    @property
    def integrator(self) -> str:
        """Return the name of the integrator."""
        return self._info.name

    @property
    def timestep_ns(self) -> int:
        """Return the fixed step, integer nanoseconds."""
        return self._timestep_ns

    @property
    def step_count(self) -> int:
        """Return the number of steps taken since the last reset."""
        return self._step_count

    @property
    def times_ns(self) -> np.ndarray:
        """Return the sim time of every body, int64 ns (a copy)."""
        return self._t.copy()

    @property
    def arrays(self) -> Tuple[np.ndarray, np.ndarray]:
        """Return read-only views ``(x (13, N), times (N,))`` of the packed state."""
        x, t = self._x.view(), self._t.view()
        x.flags.writeable = False
        t.flags.writeable = False
        return x, t

    def body_state(self, index: int) -> BodyState:
        """Return the state of body ``index`` as a :class:`BodyState` value."""
        return BodyState(**layout.unpack_state(self._x[:, index]), time_ns=int(self._t[index]))

    def reset(self, states: Optional[Iterable[BodyState]] = None) -> None:
        """Put every body back to its initial state (or to ``states``); step count 0."""
        states = self._initial_states if states is None else tuple(states)
        if len(states) != self.size:
            raise ConfigError(f'states: {len(states)} states for {self.size} bodies')
        for i, state in enumerate(states):
            if not isinstance(state, BodyState):
                raise InputError(f'states[{i}]: {state!r} is not a BodyState')
            self._x[:, i] = layout.pack_state(state)
            self._t[i] = state.time_ns
        self._t0 = self._t.copy()
        self._step_count = 0

    def set_body_loads(self, index: int, wrenches: Iterable[AppliedWrench] = (),
                       springs: Iterable[Spring] = ()) -> None:
        """Hold these loads on body ``index`` from the next step until replaced."""
        rows = _load_rows(tuple(wrenches), tuple(springs))
        if rows.shape[0] > self._loads.shape[1]:
            grown = np.zeros((self.size, rows.shape[0], layout.N_LOAD))
            grown[:, :self._loads.shape[1]] = self._loads
            self._loads = grown
        self._loads[index] = 0.0
        self._loads[index, :rows.shape[0]] = rows

    def set_wrenches_w(self, force_w: np.ndarray, torque_w: np.ndarray) -> None:
        """
        Hold a world-frame force (N, 3) N and torque (N, 3) N·m at each COM (vectorised).

        Replaces every body's loads; non-finite values raise :class:`InputError`.
        """
        force_w = np.asarray(force_w, dtype=np.float64).reshape(self.size, 3)
        torque_w = np.asarray(torque_w, dtype=np.float64).reshape(self.size, 3)
        if not (np.all(np.isfinite(force_w)) and np.all(np.isfinite(torque_w))):
            raise InputError('force_w/torque_w: batch wrench contains non-finite values (N, N·m)')
        loads = np.zeros((self.size, 1, layout.N_LOAD))
        layout.pack_wrench(loads[:, 0], layout.LOAD_WORLD, 0.0, force_w, torque_w)
        self._loads = loads

    def step(self, n: int = 1) -> None:
        """
        Advance every body ``n`` fixed steps.

        :raises NonFiniteError: if a body's step would be non-finite; that body stays at its
            last finite state (and time), the others complete all ``n`` steps.
        :raises ConvergenceError: (a :class:`NonFiniteError`) likewise, when the cause is that
            ``midpoint_cayley``'s implicit solve did not converge (``h|ω|`` too large).
        """
        if self._threads_prepare:
            self._prepare_threads()
        if self._threads_auto:
            start = time.perf_counter()
        failed = self._kernel(self._x, self._params, self._loads, self._t,
                              self._info.kernel_id, self._h, self._timestep_ns, n)
        if self._threads_auto and self._threads in self._candidates:
            self._cost_s[self._threads] = (time.perf_counter() - start) / n
            if len(self._cost_s) < len(self._candidates):
                # Measure the other candidate on the next call, once, to start with.
                self._set_threads([k for k in self._candidates if k not in self._cost_s][0])
        self._step_count += n
        if failed:
            self._raise_non_finite()

    def _raise_non_finite(self):
        expected = self._t0 + self._step_count * self._timestep_ns
        behind = np.flatnonzero(self._t != expected)
        if self._info.kernel_id == kernels.MIDPOINT_CAYLEY:
            self._raise_not_converged(behind)
        raise NonFiniteError(
            f'state: the step at t = {int(self._t[behind[0]])} ns of body(ies) '
            f'{behind[:8].tolist()} would be non-finite (forces or velocities too large for '
            f'h = {self._timestep_ns} ns with {self.integrator}); those bodies were left at '
            'their last finite state')

    def _raise_not_converged(self, behind):
        """Raise :class:`ConvergenceError` if the midpoint solve failed for one of ``behind``."""
        shared = self._params.shape[1] == 1
        failed = []
        for i in behind[:64].tolist():   # a diagnosis, not a census
            converged, speed = kernels.midpoint_solve_check(
                self._x, self._params, self._loads, i, 0 if shared else i, self._h)
            if not converged:
                failed.append((i, speed))
        if not failed:
            return
        i, speed = failed[0]
        h_s = self._h
        raise ConvergenceError(
            f'state: the implicit midpoint solve of {self.integrator} did not converge in the '
            f'step at t = {int(self._t[i])} ns of body(ies) {[b for b, _ in failed[:8]]}: '
            f'h|ω| = {h_s * speed:.3g} rad per step (h = {self._timestep_ns} ns, '
            f'|ω| = {speed:.3g} rad/s); it converges reliably for h|ω| < '
            f'{MIDPOINT_SAFE_ROTATION_RAD:g} rad: use a smaller timestep_s (< '
            f'{MIDPOINT_SAFE_ROTATION_RAD / speed:.3g} s at this spin; h|ω| << 1 rad for '
            'accuracy) or another integrator (rk4); those bodies were left at their last '
            'finite state')


class Simulator(BatchSimulator):
    """
    One rigid body: the node's and the replay's simulator.

    :param model: the :class:`BodyModel`.
    :param initial_state: a :class:`BodyState` (default: at rest at the origin, time 0).
    """

    def __init__(self, model: BodyModel, initial_state: Optional[BodyState] = None, *,
                 integrator: str = DEFAULT_INTEGRATOR, timestep_ns: int = 1_000_000):
        initial_state = BodyState() if initial_state is None else initial_state
        super().__init__(model, [initial_state], integrator=integrator,
                         timestep_ns=timestep_ns)

    @property
    def model(self) -> BodyModel:
        """Return the :class:`BodyModel`."""
        return self._models[0]

    @property
    def initial_state(self) -> BodyState:
        """Return the state :meth:`reset` goes back to."""
        return self._initial_states[0]

    @property
    def time_ns(self) -> int:
        """Return the sim time, int ns."""
        return int(self._t[0])

    @property
    def state(self) -> BodyState:
        """Return the current state, a :class:`BodyState` value."""
        return self.body_state(0)

    def reset(self, state: Optional[BodyState] = None) -> None:
        """Back to the initial state (or ``state``) and step count 0."""
        super().reset(None if state is None else [state])

    def set_loads(self, wrenches: Iterable[AppliedWrench] = (),
                  springs: Iterable[Spring] = ()) -> None:
        """Hold these loads (zero-order hold) from the next step until replaced."""
        self._loads = _load_rows(tuple(wrenches), tuple(springs))[np.newaxis]


def step(model: BodyModel, state: BodyState, *, integrator: str = DEFAULT_INTEGRATOR,
         timestep_ns: int = 1_000_000, wrenches: Iterable[AppliedWrench] = (),
         springs: Iterable[Spring] = ()) -> BodyState:
    """Return the state one step after ``state`` (the value form of :class:`Simulator`)."""
    simulator = Simulator(model, state, integrator=integrator, timestep_ns=timestep_ns)
    simulator.set_loads(wrenches, springs)
    simulator.step()
    return simulator.state


def net_wrench_w(model: BodyModel, state: BodyState, wrenches: Iterable[AppliedWrench] = (),
                 springs: Iterable[Spring] = ()) -> Tuple[np.ndarray, np.ndarray]:
    """
    Net force (N) and torque about the COM (N·m), world coordinates, acting on the body.

    The same compiled function the integrators use (:func:`kernels.net_wrench_w`).
    """
    jitcache.configured()  # the kernel cache, before a first compile
    x = layout.pack_state(state)[:, np.newaxis]
    out = np.empty((6, 1))
    kernels.net_wrench_batch(x, layout.pack_params(model)[:, np.newaxis],
                             _load_rows(tuple(wrenches), tuple(springs))[np.newaxis], out)
    return out[0:3, 0], out[3:6, 0]


def accelerations(model: BodyModel, state: BodyState,
                  wrenches: Iterable[AppliedWrench] = (),
                  springs: Iterable[Spring] = ()) -> Tuple[np.ndarray, np.ndarray]:
    """
    Newton–Euler accelerations ``(a_w, α_w)`` at ``state`` (damping excluded).

    ``M a = F`` and ``I α = τ − ω × I ω`` in world coordinates with ``I = R I_b Rᵀ``.
    """
    force_w, torque_w = net_wrench_w(model, state, wrenches, springs)
    inertia_w = state.inertia_w(model)
    omega_w = state.angular_velocity_w()
    alpha_w = np.linalg.solve(inertia_w, torque_w - np.cross(omega_w, inertia_w @ omega_w))
    return force_w / model.mass_kg, alpha_w
