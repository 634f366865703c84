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
Row layouts and tolerances of the contact step, and the compile options of its stages.

The contact table (``C_*``), the patch table (``Q_*``), the response cache (``R_*``) and the
warm-start table (``W_*``) are float64 arrays indexed by these constants; every stage module
of :mod:`rbd_ros.core.contact` reads and writes them by name.  The tolerances say where each
value comes from.  ``_jit``, ``_inl`` and ``_raw`` are the three ways a stage is compiled (see
:mod:`rbd_ros.core.contact.step`, "Reference counts").  The arrays that travel between the
stages travel as named tuples (numba compiles their fields as a struct): :class:`Shapes`,
:class:`Statics` and :class:`Work`; the pair rule of materials is :func:`pair_material`.
"""

from collections import namedtuple
import math

from rbd_ros.core import jitcache


PHASE_COLLISION = 0
PHASE_CONTACT = 1
#: Candidate φ (m) below which a point is a (speculative) contact.
MARGIN_M = 1e-3
#: A point within this gap (m) of the other shape counts as touching now.
TOUCH_M = 1e-5
#: Share of a penetration depth the impulses remove per step, and the speed cap of that.
PUSH_FRACTION = 0.2
PUSH_MAX_M_S = 0.1
#: Gauss–Seidel sweeps over all patches per stage, and the iterations of one patch.
SWEEPS = 24
PATCH_ITERATIONS = 64
#: A sweep that changes no velocity by more than this (m/s) ends the stage early; a patch's
#: iterations end once its friction changes none by more.
VELOCITY_TOL_M_S = 1e-13
#: A sweep that changes no point's relative velocity by more than this (m/s) in all ends the
#: stage early too (see solve_stage).
SWEEP_TOL_M_S = 1e-12
#: A patch none of whose points approaches faster than its target by more than this (m/s)
#: takes no normal impulse (:func:`_idle`): the sweeps' own tolerance.  Below it a point may
#: sink at most this fast, until the push-out of its depth (20 % of it a step) outruns it:
#: at a depth of 5 h × this, 5e-15 m at 1 ms.  Boxes side by side, touching and pressing
#: nothing, have depths and relative velocities of round-off (~1e-17 m, ~1e-13 m/s): judged
#: exactly, about half their patches were solved in every sweep and all in shock propagation:
#: ~85 % of a step of 1000 of them (40 ms against 7.7 for MuJoCo).
IDLE_TOL_M_S = SWEEP_TOL_M_S
#: A point given its patch's normal takes its depth along it (see _consistent_normals) only
#: where that is deeper than its φ by more than this (m).  Differences at round-off are left
#: alone: they only reorder _reduce's near-ties, and a grid of boxes side by side, whose
#: diagonal neighbours meet edge to edge as wedges balanced at round-off, started to move
#: when they were taken (1000 boxes: 1e-8 J within 6 steps).  A flush stack can sink at most
#: this far before its corners show the depth.
FLUSH_DEPTH_MIN_M = 1e-12
#: ... and only where the step left the other shape along the patch normal: a step of length
#: ``s`` that leaves by a face at an angle α to it reads ``s (1 − cos α)`` too deep, which
#: may be at most this (m).  Boxes side by side meet their diagonal neighbours edge to edge;
#: before ck.EDGE_ROUNDOFF_M their patch normal could be tilted from the faces by 7°, which
#: read as 1.8 µm of depth.  The push-out could not remove it (the grid is jammed), so the
#: sweeps ran to their cap every stage: a step of 1000 such boxes took 3.5–7 s instead of
#: 0.3 s.  1e-11 m keeps a corner 5e-8 m outside the other box's side (α = 2e-4 rad) reading
#: the face's depth.
DEPTH_READ_ERROR_M = 1e-11
#: At most this many points per patch.
PATCH_POINTS = 4
#: A patch's friction acts at the λ-weighted mean of its points.  While every coordinate of
#: it is within this (m) it is taken in world coordinates, ``c = Σ λ_k p_k / Σ λ_k``, its lever
#: arms ``c − x``: their round-off, a few ulp of ``|c|`` (~4e-9 m at 1e7 m), is nothing beside
#: a body (and the recorded worlds keep their bits).  Further out that round-off is the lever
#: arms' error, an ulp of 1e284 m at 1e300 m, and r²/I overflows; there they are the λ-weighted
#: means of the points' own (``C_RA``, ``C_RB``: as exact as a body's size wherever it is).
CENTRE_WORLD_MAX_M = 1e7
#: Surface points are grouped in cells of this many, a cell skipped when its ball is out of
#: reach (see _one_way).
CHUNK_POINTS = 16
#: A Lipschitz bound of a mesh's φ: the trilinear interpolant of exact distances has
#: |∂φ/∂x_k| <= 1 in a cell (|∇φ| <= √3), and outside the grid box φ adds the distance to it.
PHI_LIPSCHITZ_MESH = 1.0 + math.sqrt(3.0)
#: Slack (m) on the skip test of a cell, against round-off in φ at its centre.
CULL_SLACK_M = 1e-9
#: How much depth counts against reach when _reduce picks a patch's extreme points (m/m):
#: 2 or more keeps a box under a push inside its cone on an equal box still; 10 let the
#: 5-layer pyramid at 10 ms drift 8 µm; 4 keeps both (and the 10-box column) at rest.
REDUCE_DEPTH_WEIGHT = 4.0

# Contact record fields (rows of the (C, N_CONTACT) float64 contact table).
C_A = 0          # body index of A
C_B = 1          # body index of B, or N + s for static object s
C_POINT = 2      # world contact point (current configuration), 3
C_NORMAL = 5     # unit normal: the impulse on A is along +n, 3
C_RA = 8         # lever arm from A's COM, 3
C_RB = 11        # lever arm from B's COM (0 for static), 3
C_BIAS = 14      # target: u_n >= bias after the stage (m/s)
C_LAMBDA = 15    # accumulated normal impulse (N·s)
C_PHI = 16       # candidate φ (m)
C_FRICTION = 17  # this point's share of the patch friction impulse (N·s), 3
C_PHASE = 20     # the stage: 0 collision, 1 first contact stage, 2 second
C_TARGET = 21    # the target without restitution (m/s): C_BIAS of a contact stage
C_TOUCH_U = 22   # restitution applies while u_n is below this (m/s): the point then ends the
#                  step within TOUCH_M of the other shape (see _collision_targets)
C_TK = 23        # the point's 2×2 tangential response (k11, k12, k22) of body A, then of B,
#                  fixed within a stage: kept once computed (see _friction_points), 6
C_TK_SET = 29    # 1.0 once C_TK holds them, 0.0 from the narrow phase
N_CONTACT = 30

# Patch record fields (rows of the (Q, N_PATCH) float64 patch table).
Q_A = 0
Q_B = 1
Q_START = 2      # first contact row
Q_COUNT = 3
Q_MU = 4
Q_FT = 5         # accumulated tangential friction impulse, world vector, 3
Q_MT = 8         # accumulated torsional couple about the patch normal (N·m·s)
Q_NORMAL = 9     # patch normal (unit, λ-weighted mean), 3
Q_CACHED = 12    # Q_K and Q_PINV hold this stage's normal response (both bodies free): 1.0
#                  computed in this stage, 2.0 taken from the response cache (R_*), else 0.0
Q_K = 13         # K_nn of the points, row-major PATCH_POINTS², fixed within a stage
Q_PINV = 29      # its pseudo-inverse, the same layout
Q_EPS = 45       # restitution of the pair in the collision stage, else 0 (see solve_patch)
N_PATCH = 46

# Response cache of a body's patch on a static object (rows of the (N, N_RESPONSE) table kept
# from stage to stage and step to step): the patch's K and pseudo-inverse with what they are a
# function of.  A body at rest meets the same lever arms, normals and inverse inertia from
# one stage to the next, bit for bit (always from the last stage of a step to the first of
# the next, which no drift separates); a hit reuses the values, so results are the same as
# recomputing them, whatever the cache held before.
R_STATIC = 0     # the static object's index (N + s), or -1 for none
R_COUNT = 1      # the patch's points
R_ROWS = 2       # per point: lever arm from A's COM (3) and normal (3)
R_INV_MASS = R_ROWS + 6 * PATCH_POINTS
R_INV_INERTIA = R_INV_MASS + 1   # R I_b⁻¹ Rᵀ of A, row-major, 9
R_K = R_INV_INERTIA + 9
R_PINV = R_K + PATCH_POINTS * PATCH_POINTS
N_RESPONSE = R_PINV + PATCH_POINTS * PATCH_POINTS

# Warm start of coupled contact stages (the (3, N, W_SLOTS, W_FIELDS) table and its (3, N)
# counts, kept from step to step, one row per stage of the step): a stage whose patches share
# bodies (a stack) starts its Gauss–Seidel sweeps from the normal impulses the same stage of
# the last step ended its sweeps with (before shock propagation), instead of from zero.  From
# zero the sweeps converge by ~0.8 a sweep in a pyramid and ran to their cap every step, so
# shock propagation finished the job and recorded the lower boxes' reactions short (it
# moves only the upper body); from the last step's answer a resting stack is done in two or
# three sweeps.  Rows per body A (the pair's lower index), one per patch, at most W_SLOTS.
# A point takes the λ of the last step's point of the same pair within WARM_MATCH_M in A's
# body frame, and only where its normal is within 60° of gravity (WARM_COS_MIN): what holds
# weight up.  A body with a neighbour beside it (a patch whose normal is not within 60° of
# gravity) carries its load over, not how the load is spread: the matched points of its
# patches all start from the mean of their kept impulses.  Carried point by point, a spread
# that leaned a box (more weight on its outer corners, neighbours pressing its top) leaned
# it again the next step: boxes side by side built an arch pressing each other at the top,
# held by the floor's friction, ~20 % stronger a step, until the sweeps ran to their cap
# every stage (1000 boxes: 3.5–7 s a step from step ~55).  Elsewhere the spread is carried:
# a pyramid's lower boxes bear their loads off centre, and from the mean its sweeps ended
# short of converged every step (recorded reactions off by 0.16 N, as from zero).
# Sideways contacts start from zero: carried over, they let boxes side by side squeeze each
# other, held by the floor's friction, until the squeeze let go.  For the same reason a point
# carries its friction impulse (projected onto its tangent plane, clamped to its cone μ λ)
# only where its body's load is carried point by point (no neighbour beside it).
# A warm-started stage whose answer still violates the normal conditions by more than
# WARM_LEFT_MAX_M_S (see _residual) is solved again from zero (see solve_stage).
W_SLOTS = 8
W_B = 0          # the other body (N + s for a static object)
W_COUNT = 1      # the patch's points
W_POINTS = 2     # per point: from A's COM in A's frame (3), then λ, then friction (3, A's frame)
W_STRIDE = 7
W_FIELDS = W_POINTS + W_STRIDE * PATCH_POINTS
WARM_MATCH_M = 1e-4
WARM_COS_MIN = 0.5
WARM_LEFT_MAX_M_S = 1e-6

# Counters of the contact islands whose patches share bodies, per stage of the step (rows of
# the (3, N_SOLVE_STATS) float64 table ``Work.stats``, summed from step to step until the
# simulator resets them; see WorldSimulator.solve_stats): what bench_contact.py prints per
# stage.
ST_STAGES = 0    # coupled islands solved (a jointed world's coupled stages: one group each)
ST_SWEEPS = 1    # Gauss–Seidel sweeps run (a cold retry's included)
ST_COLD = 2      # warm-started islands solved again from zero (see solve_islands)
ST_PATCHES = 3   # patches of those islands
N_SOLVE_STATS = 4

_jit = jitcache.kernel()
_inl = jitcache.kernel(inline='always')
#: Functions that allocate nothing (the loops per pair, per patch, per body) are compiled
#: without numba's reference counting (see :mod:`rbd_ros.core.contact.step`, "Reference counts").
_raw = jitcache.raw_kernel()


#: The shape table, one entry a shape (the bodies', then the static objects'), built once by
#: :class:`~rbd_ros.core.contact.simulator.WorldSimulator`: ``kinds`` (``ck.KIND_*``),
#: ``sparams`` (the shape parameters); the surface points ``pts`` of shape ``s`` are rows
#: ``pt_off[s]:pt_off[s + 1]`` (body frame, m), the points that can be lowest against a plane
#: ``ppts``/``ppt_off``; ``pt_radius`` a sphere's or capsule's radius (m); ``bound_r`` the
#: bounding radius (m); the φ grids of meshes flattened in ``grid_data`` at ``grid_off`` with
#: shape ``grid_dim``; the materials' friction ``mu`` and restitution ``eps``; the cells of
#: surface points (see ``points._one_way``): their balls ``balls`` (centre, radius) at
#: ``ball_off``, and each point's cell ``cell_of``.
Shapes = namedtuple('Shapes', ('kinds', 'sparams', 'pts', 'pt_off', 'ppts', 'ppt_off',
                               'pt_radius', 'bound_r', 'grid_data', 'grid_off', 'grid_dim',
                               'mu', 'eps', 'balls', 'ball_off', 'cell_of', 'skip'))
#: The static objects, one entry each: their shape kind and parameters, world pose (rotation
#: ``rot`` (S, 3, 3), position ``pos`` (S, 3), m) and world bounds ``lo``/``hi`` (S, 3, m).
Statics = namedtuple('Statics', ('kind', 'params', 'rot', 'pos', 'lo', 'hi'))
#: The per-body work arrays of the step, kept between stages and steps: world velocities
#: ``vel`` (N, 6: v then ω), ``inv_mass`` (1/kg), ``inv_inertia_w`` (N, 3, 3, world), current
#: rotation ``rot``, candidate position ``pos_c`` and rotation ``rot_c``, ``touched`` (a body
#: with a patch this stage), the response cache ``responses`` (N, N_RESPONSE) and the warm
#: start ``warm`` (3, N, W_SLOTS, W_FIELDS) with its counts ``warm_n`` (3, N), and the solve
#: counters ``stats`` (3, N_SOLVE_STATS), and ``span`` (N, 6): the low then high corner of
#: the union of every broad-phase box of each body since it was last reset (by the caller):
#: what the parallel step (``contact.parallel``) checks its groups against.
Work = namedtuple('Work', ('vel', 'inv_mass', 'inv_inertia_w', 'rot', 'pos_c', 'rot_c',
                           'touched', 'responses', 'warm', 'warm_n', 'stats', 'span'))


@_inl
def pair_material(mu_a, eps_a, mu_b, eps_b):
    """
    Return the pair rule of two materials: ``(μ, ε) = (sqrt(μ_a μ_b), max(ε_a, ε_b))``.

    The one home of the rule: the narrow phase puts it in each patch (``Q_MU``, ``Q_EPS``) and
    :meth:`~rbd_ros.core.contact.world.Material.combine` returns it.
    """
    return math.sqrt(mu_a * mu_b), max(eps_a, eps_b)
