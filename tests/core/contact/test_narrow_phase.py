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
The narrow phase's shortcuts against the plain search they stand for.

``_one_way`` skips a cell of surface points when φ at the cell's centre, less the cell's
radius times φ's Lipschitz bound, is out of reach.  That must never lose a point: the rows it
returns (and so every contact) must be bit for bit those of trying every point, which is what
a cell of infinite radius does.  Checked on every pair kind (primitives, a mesh, a static
mesh, the plane) in random close poses, shapes interpenetrating or just apart.

And the depth a box shows where it rests on an equal box with their sides flush: its corners
lie on the lower box's side planes, where φ is the distance to a side (about 0) whatever the
depth below the top face; the patch must still show that depth along its normal.
"""

import pathlib

import numpy as np
import pytest
from rbd_ros.core import layout
from rbd_ros.core.contact import (ground_plane, load_mesh, Material, obstacle,
                                  primitive_shape, StaticWorld)
from rbd_ros.core.contact import rows as cs
from rbd_ros.core.contact.bodies import prepare_bodies
from rbd_ros.core.contact.broad_phase import broad_phase
from rbd_ros.core.contact.manifold import _consistent_normals
from rbd_ros.core.contact.narrow_phase import narrow_phase
from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
from rbd_ros.core.model import BodyModel
from rbd_ros.core.state import BodyState

SEED = 20261127
L_BLOCK = pathlib.Path(__file__).resolve().parents[3] / 'msg_config' / 'meshes' / 'l_block.stl'


def build():
    """One body of every kind (the primitives and the nonconvex L-block mesh) and statics."""
    shapes = [primitive_shape('box', [0.2, 0.15, 0.1]), primitive_shape('sphere', [0.07]),
              primitive_shape('cylinder', [0.06, 0.18]),
              primitive_shape('capsule', [0.05, 0.12]),
              primitive_shape('ellipsoid', [0.1, 0.07, 0.05]), load_mesh(str(L_BLOCK))]
    bodies = []
    for k, shape in enumerate(shapes):
        model = BodyModel(1.0, shape.mass_properties(1.0).inertia_b)
        bodies.append(WorldBody(f'b{k}', model, shape, Material(0.5, 0.0)))
    # Far apart at build (overlaps are refused there); the test poses them itself.
    states = [BodyState(position_w=(3.0 * k, 0.0, 1.0)) for k in range(len(bodies))]
    static = StaticWorld(ground_plane(), [
        obstacle('post', 'cylinder', [0.08, 0.4], position_w=(0.15, 0.1, 0.2)),
        obstacle('slab', 'box', [0.3, 0.3, 0.05], position_w=(-0.2, -0.1, 0.1)),
        obstacle('ell', 'mesh', mesh_path=str(L_BLOCK), position_w=(0.1, -0.2, 0.05))])
    return WorldSimulator(bodies, states, static, timestep_ns=1_000_000)


def contacts(sim, x, geo, stage):
    """Run the narrow phase of one contact stage on state ``x`` with the shape table ``geo``."""
    statics = sim._statics
    n = x.shape[1]
    work = cs.Work(vel=np.zeros((n, 6)), inv_mass=np.zeros(n), inv_inertia_w=np.zeros((n, 3, 3)),
                   rot=np.zeros((n, 3, 3)), pos_c=np.zeros((n, 3)), rot_c=np.zeros((n, 3, 3)),
                   touched=np.zeros(n, dtype=np.bool_),
                   responses=np.full((n, cs.N_RESPONSE), -1.0),
                   warm=np.zeros((3, n, cs.W_SLOTS, cs.W_FIELDS)),
                   warm_n=np.zeros((3, n), dtype=np.int64),
                   stats=np.zeros((3, cs.N_SOLVE_STATS)), span=np.zeros((n, 6)))
    h = 1e-3
    prepare_bodies(x, sim._params, work.vel, work.inv_mass, work.inv_inertia_w, work.rot,
                   work.pos_c, work.rot_c, h, False)
    pairs = broad_phase(x, work.pos_c, geo.bound_r, n, statics.kind, statics.params, statics.lo,
                        statics.hi, cs.MARGIN_M, geo.skip, work.span)
    return narrow_phase(pairs, n, x, sim._params, work, statics, geo, h, cs.PHASE_CONTACT, stage)


def test_skipping_cells_keeps_every_contact_bit_for_bit():
    sim = build()
    geo = sim._geo
    plain = geo._replace(balls=geo.balls.copy())
    plain.balls[:, 3] = np.inf  # no cell can be skipped: every point is tried
    rng = np.random.default_rng(SEED)
    n = sim.size
    found = 0
    for _ in range(60):
        x = sim.arrays[0].copy()
        # Bodies packed into a 0.6 m box around the post, the slab and the static L, turned
        # and moving at random: most pairs touch, overlap or pass within the margin.
        x[layout.S_POS:layout.S_POS + 3] = rng.uniform([-0.3, -0.3, 0.0], [0.3, 0.3, 0.35],
                                                       (n, 3)).T
        quat = rng.normal(size=(n, 4))
        x[layout.S_QUAT:layout.S_QUAT + 4] = (quat / np.linalg.norm(quat, axis=1)[:, None]).T
        x[layout.S_VEL:layout.S_VEL + 3] = rng.normal(0.0, 0.5, (3, n))
        x[layout.S_OMEGA:layout.S_OMEGA + 3] = rng.normal(0.0, 2.0, (3, n))
        for stage in (1, 2):
            got_c, got_q = contacts(sim, x, geo, stage)
            want_c, want_q = contacts(sim, x, plain, stage)
            np.testing.assert_array_equal(got_c, want_c)
            np.testing.assert_array_equal(got_q[:, :cs.Q_K], want_q[:, :cs.Q_K])
            found += len(want_c)
    # Not vacuous: the poses made contacts (hundreds of points over the trials).
    assert found > 500, found
    # And the cells are compact enough to be skipped: every cell of a shape with more than one
    # cell is well inside the shape's bounding ball (measured: box cells 0.003–0.05 m against
    # its 0.14 m; a cell as wide as the shape would never be skipped).
    for s in range(n):
        cells = geo.balls[geo.ball_off[s]:geo.ball_off[s + 1]]
        if len(cells) > 1:
            assert cells[:, 3].max() < 0.75 * sim.bodies[s].shape.bounding_radius_m, s


@pytest.mark.parametrize('shift_m', [0.0, 1e-9, -1e-9, 3e-8])
def test_a_box_sunk_into_an_equal_box_shows_its_depth_at_every_point(shift_m):
    # Two 0.2 m boxes, the upper sunk 1e-7 m into the lower and shifted sideways by less than
    # that in x and y, so its bottom corners and edges lie a hair inside or outside the lower
    # box's side planes.  The depth is read from the poses, not from the kernels.
    side = 0.2
    depth = 1e-7
    box = primitive_shape('box', [side] * 3)
    model = BodyModel(1.0, box.mass_properties(1.0).inertia_b)
    bodies = [WorldBody(f'b{k}', model, box, Material(0.5, 0.0)) for k in range(2)]
    states = [BodyState(position_w=(0.0, 0.0, 0.5 * side)),
              BodyState(position_w=(shift_m, shift_m, 1.5 * side - depth))]
    sim = WorldSimulator(bodies, states, StaticWorld(ground_plane()), timestep_ns=1_000_000)
    x = sim.arrays[0].copy()
    want = (x[layout.S_POS + 2, 0] + 0.5 * side) - (x[layout.S_POS + 2, 1] - 0.5 * side)
    assert abs(want - depth) < 1e-15
    for stage in (1, 2):
        found, patches = contacts(sim, x, sim._geo, stage)
        pair = found[(found[:, cs.C_A] == 0) & (found[:, cs.C_B] == 1)]
        # The patch spans the face: four points (a three-point patch would tip the box).
        assert len(pair) == cs.PATCH_POINTS
        # Every point has the face's normal (the impulse on the lower box is along −z) to
        # round-off: a sideways or tilted normal here is what tipped a flush column over.
        np.testing.assert_allclose(pair[:, cs.C_NORMAL:cs.C_NORMAL + 3],
                                   np.tile([0.0, 0.0, -1.0], (len(pair), 1)), rtol=0,
                                   atol=1e-15)
        # And the depth, read a step s = MARGIN_M / 4 out along the normal: a point a shift e
        # outside the lower box's sides (in x and y) reads sqrt(2 e² + (s − depth)²) − s,
        # less deep by ~e²/s (3.6e-12 m at e = 3e-8 m); plus the round-off of coordinates
        # near 0.3 m (5.6e-17 m each; a few operations: 1e-15 m).  The old φ at a corner was
        # the shift, 0 to 3e-8 m, which showed no depth to push out.
        bound = 1.01 * shift_m ** 2 / (0.25 * cs.MARGIN_M) + 1e-15
        np.testing.assert_allclose(pair[:, cs.C_PHI], -want, rtol=0, atol=bound)


def test_a_patch_normal_tilted_from_the_face_a_point_leaves_by_reads_no_depth():
    # The depth a point shows along the patch normal n̄ is read by a step s out of the other
    # shape: φ(p + s n̄) − s.  That is the depth only where the step leaves by a face whose
    # normal is n̄; leaving by a face at 5° from it, a point on that face (depth 0) read
    # s (1 − cos 5°) = 9.5e-7 m of depth, which the push-out then tried to remove (boxes
    # side by side, their diagonal neighbours' patch normals tilted by round-off, could not
    # give way: their sweeps ran to the cap every stage).  Here the rows are made by hand:
    # three points with the tilted normal n̄ = (cos 5°, sin 5°, 0) (the patch's) and one point
    # exactly on body 1's +x face, p = (0.1, 0, 0) in its frame, with the face's normal.
    box = primitive_shape('box', [0.2, 0.2, 0.2])
    model = BodyModel(1.0, box.mass_properties(1.0).inertia_b)
    bodies = [WorldBody(f'b{k}', model, box, Material(0.5, 0.0)) for k in range(2)]
    states = [BodyState(position_w=(3.0 * k, 0.0, 1.0)) for k in range(2)]
    sim = WorldSimulator(bodies, states, StaticWorld(ground_plane()), timestep_ns=1_000_000)
    kinds, sparams = sim._geo.kinds, sim._geo.sparams
    grid_data, grid_off, grid_dim = sim._geo.grid_data, sim._geo.grid_off, sim._geo.grid_dim
    tilt = np.radians(5.0)
    n_bar = [np.cos(tilt), np.sin(tilt), 0.0]
    buf = np.zeros((4, 11))
    for k in range(3):
        buf[k] = [-1e-9, 0.0, 0.0, 0.0, *n_bar, 0.1, 0.0, 0.01 * k, 1.0]
    buf[3] = [0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.1, 0.0, 0.0, 1.0]
    pose_rc = np.tile(np.eye(3), (3, 1, 1))
    got = _consistent_normals(buf, 4, 0, 1, kinds, sparams, grid_data, grid_off, grid_dim,
                              pose_rc)
    np.testing.assert_array_equal(got, n_bar)
    # The point takes the patch's normal (φ rises by s cos 5°, within the 1 % the test on
    # the normal allows)...
    np.testing.assert_array_equal(buf[3, 4:7], n_bar)
    # ... but keeps φ = 0: the step left by the +x face, not along n̄.
    assert buf[3, 0] == 0.0
