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
The start-overlap depth per shape pair against closed forms (issue 30 item 1).

Exact pairs (a plane, two boxes, spheres and capsules, a sphere in a convex shape) are checked
to round-off; the lower-bound pairs (cylinders, ellipsoids, meshes) against the depth they must
reach for flat-faced, coincident and crossing overlaps, and never above round-off for bodies
placed exactly in contact, whatever the pair.
"""

import itertools
import math

import numpy as np
import pytest
from rbd_ros.core.contact import (check_overlaps, ground_plane, mesh_shape, obstacle,
                                  penetration_depth, primitive_shape, StaticWorld)
from rbd_ros.core.errors import ModelError
from rbd_ros.core.rotations import quat_from_axis_angle
import trimesh

IDENTITY = (1.0, 0.0, 0.0, 0.0)
# float64 round-off on coordinates and depths of order 1 m (a few ulps of 2.2e-16).
ROUND_OFF = 1e-12
# The lower-bound search halves its step down to 1e-9 of the smaller bounding radius (~0.1 m
# here), so it stops within ~1e-10 m of its optimum; 1e-8 m leaves a factor 100.
SEARCH = 1e-8
SHAPES = {'box': [0.2, 0.3, 0.1], 'sphere': [0.1], 'cylinder': [0.1, 0.3],
          'capsule': [0.08, 0.2], 'ellipsoid': [0.15, 0.1, 0.08]}


def _shape(name):
    return primitive_shape(name, SHAPES[name])


def _depth(a, pa, b, pb, qa=IDENTITY, qb=IDENTITY):
    return penetration_depth(a, pa, qa, b, pb, qb)[0]


def test_two_spheres_overlap_by_the_sum_of_radii_less_the_distance():
    small, big = primitive_shape('sphere', [0.1]), primitive_shape('sphere', [0.3])
    for d in (0.0, 0.1, 0.25, 0.399):
        direction = np.array([1.0, 2.0, -2.0]) / 3.0
        depth = _depth(small, [0.0, 0.0, 0.0], big, d * direction)
        assert depth == pytest.approx(0.4 - d, abs=ROUND_OFF)


def test_two_boxes_by_separating_axes():
    cube = primitive_shape('box', [0.2, 0.2, 0.2])
    # Face to face along x: overlap 0.2 - x.
    assert _depth(cube, [0.0, 0.0, 0.0], cube, [0.17, 0.05, -0.02]) == pytest.approx(
        0.03, abs=ROUND_OFF)
    # Turned 45° about z, a vertical edge first: B reaches x - 0.1 √2, so the least push is
    # along x, 0.1 + 0.1 √2 - x (B's own face normals need 0.1 √2 + 0.1 - x / √2, more).
    q = quat_from_axis_angle([0.0, 0.0, 1.0], math.pi / 4)
    for x in (0.2, 0.22, 0.24):
        assert _depth(cube, [0.0, 0.0, 0.0], cube, [x, 0.0, 0.0], qb=q) == pytest.approx(
            0.1 + 0.1 * math.sqrt(2.0) - x, abs=ROUND_OFF)
    # Edge across edge: A turned 45° about x (its top edge along x), B turned 45° about y
    # above it (its bottom edge along y); each edge is 0.1 √2 from its centre along z, and
    # the least push is the edge-edge axis z.
    qa = quat_from_axis_angle([1.0, 0.0, 0.0], math.pi / 4)
    qb = quat_from_axis_angle([0.0, 1.0, 0.0], math.pi / 4)
    for z in (0.25, 0.28):
        assert _depth(cube, [0.0, 0.0, 0.0], cube, [0.0, 0.0, z], qa, qb) == pytest.approx(
            0.2 * math.sqrt(2.0) - z, abs=ROUND_OFF)
    # Apart by 5 cm along x: the separation, negative.
    assert _depth(cube, [0.0, 0.0, 0.0], cube, [0.25, 0.0, 0.0]) == pytest.approx(
        -0.05, abs=ROUND_OFF)


def test_a_long_box_through_another_is_found_with_both_centres_outside_the_other():
    # Issue 30: surface points of two crossing bars can all miss the other bar. A bar along x
    # and a bar along y crossing it off both centres (0.44 m along A, 0.6 m from B's centre):
    # the least push is along z, the full 0.1 m thickness (sideways takes 0.45 or 0.61 m).
    bar_x = primitive_shape('box', [2.0, 0.1, 0.1])
    bar_y = primitive_shape('box', [0.1, 2.0, 0.1])
    depth = _depth(bar_x, [0.0, 0.0, 0.0], bar_y, [0.44, 0.6, 0.0])
    assert depth == pytest.approx(0.1, abs=ROUND_OFF)
    # A 3 m bar through the middle of a 1 m cube: out sideways, 0.5 + 0.05 m.
    cube = primitive_shape('box', [1.0, 1.0, 1.0])
    rod = primitive_shape('box', [3.0, 0.1, 0.1])
    assert _depth(cube, [0.0, 0.0, 0.0], rod, [0.0, 0.0, 0.0]) == pytest.approx(
        0.55, abs=ROUND_OFF)
    with pytest.raises(ModelError, match=r'^bodies\.bar\.position_w: .* 0\.1 m deep inside '
                                         r'bodies\.cross'):
        check_overlaps([('bar', bar_x, [0.0, 0.0, 0.0], IDENTITY),
                        ('cross', bar_y, [0.44, 0.6, 0.0], IDENTITY)])


def test_capsules_by_the_distance_of_their_core_segments():
    cap = primitive_shape('capsule', [0.1, 0.4])  # core z in [-0.2, 0.2]
    across = quat_from_axis_angle([1.0, 0.0, 0.0], math.pi / 2)  # core along y
    # Crossing at right angles, cores 0.15 m apart along x: 0.2 - 0.15.
    assert _depth(cap, [0.0, 0.0, 0.0], cap, [0.15, 0.0, 0.1], qb=across) == pytest.approx(
        0.05, abs=ROUND_OFF)
    # Coaxial, end to end: the poles overlap by 2 r + 2 hl - d.
    assert _depth(cap, [0.0, 0.0, 0.0], cap, [0.0, 0.0, 0.55]) == pytest.approx(
        0.05, abs=ROUND_OFF)
    # A sphere against a capsule's side.
    ball = primitive_shape('sphere', [0.05])
    assert _depth(ball, [0.12, 0.0, 0.1], cap, [0.0, 0.0, 0.0]) == pytest.approx(
        0.03, abs=ROUND_OFF)


def test_a_sphere_in_a_convex_shape_is_r_minus_phi():
    ball = primitive_shape('sphere', [0.05])
    cylinder = primitive_shape('cylinder', [0.2, 0.4])
    # Centre 0.03 m inside the side: r + 0.03.
    assert _depth(ball, [0.17, 0.0, 0.0], cylinder, [0.0, 0.0, 0.0]) == pytest.approx(
        0.08, abs=ROUND_OFF)
    # Outside the rim by (0.03, 0.04): 0.05 m away, touching.
    assert _depth(ball, [0.23, 0.0, 0.24], cylinder, [0.0, 0.0, 0.0]) == pytest.approx(
        0.0, abs=ROUND_OFF)


def test_a_shape_below_a_plane_by_its_support_function():
    ground = ground_plane()
    tilt = 0.4
    q = quat_from_axis_angle([1.0, 0.0, 0.0], tilt)
    ell = primitive_shape('ellipsoid', [0.3, 0.2, 0.1])
    # The lowest point of an ellipsoid turned by θ about x: sqrt((b sin θ)² + (c cos θ)²).
    reach = math.hypot(0.2 * math.sin(tilt), 0.1 * math.cos(tilt))
    assert _depth(ell, [0.0, 0.0, 0.1], ground.shape, [0.0, 0.0, 0.0], qa=q) == pytest.approx(
        reach - 0.1, abs=ROUND_OFF)
    cyl = primitive_shape('cylinder', [0.1, 0.4])
    # A cylinder's lowest rim point: r sin θ + hl cos θ.
    reach = 0.1 * math.sin(tilt) + 0.2 * math.cos(tilt)
    assert _depth(cyl, [0.0, 0.0, 0.2], ground.shape, [0.0, 0.0, 0.0], qa=q) == pytest.approx(
        reach - 0.2, abs=ROUND_OFF)


@pytest.mark.parametrize('name', sorted(SHAPES))
def test_coincident_identical_shapes_overlap_by_their_thinnest_width(name):
    # Separating two identical convex bodies at one pose takes their thinnest width (twice
    # the inradius for these primitives; a capsule's is 2 r).
    body = _shape(name)
    q = quat_from_axis_angle([1.0, 1.0, 0.0], 0.7)
    width = {'box': 0.1, 'sphere': 0.2, 'cylinder': 0.2, 'capsule': 0.16, 'ellipsoid': 0.16}
    depth = _depth(body, [1.0, -2.0, 0.5], body, [1.0, -2.0, 0.5], q, q)
    assert depth == pytest.approx(width[name], abs=SEARCH)


@pytest.mark.parametrize('pair', list(itertools.combinations_with_replacement(sorted(SHAPES),
                                                                              2)))
def test_every_pair_stacked_exactly_in_contact_is_accepted_and_5_mm_deep_refused(pair):
    # B's lowest point placed on A's highest one, offset sideways so the contact is off both
    # axes for flat faces: a touching pair has depth 0 (round-off), 5 cm apart is accepted,
    # 5 mm deep (B lowered by 5 mm) is above the 1 mm tolerance.
    a, b = _shape(pair[0]), _shape(pair[1])
    top_a, bottom_b = float(a.aabb_max_b[2]), float(-b.aabb_min_b[2])
    side = 0.01 if 'box' in pair or 'cylinder' in pair else 0.0
    for gap in (0.0, 0.05):
        z = top_a + bottom_b + gap
        assert _depth(a, [0.0, 0.0, 0.0], b, [side, side, z]) <= ROUND_OFF - gap
        check_overlaps([('a', a, [0.0, 0.0, 0.0], IDENTITY),
                        ('b', b, [side, side, z], IDENTITY)])
    deep = _depth(a, [0.0, 0.0, 0.0], b, [side, side, top_a + bottom_b - 0.005])
    # Flat faces on each other overlap by exactly 5 mm; curved ones by less (the depth of a
    # lowered ball in a ball of radius ~0.1 m lowered 5 mm is ~3.4 mm), never above 5 mm.
    assert 1e-3 < deep <= 0.005 + SEARCH
    with pytest.raises(ModelError, match=r'deep inside bodies\.b'):
        check_overlaps([('a', a, [0.0, 0.0, 0.0], IDENTITY),
                        ('b', b, [side, side, top_a + bottom_b - 0.005], IDENTITY)])


def test_side_by_side_and_resting_stacks_are_accepted():
    # A row of each shape side by side touching, and a column of cylinders, on the ground.
    world = StaticWorld(ground_plane())
    bodies = []
    for k, name in enumerate(sorted(SHAPES)):
        shape = _shape(name)
        width = 2.0 * float(shape.aabb_max_b[0])
        z = float(-shape.aabb_min_b[2])
        bodies += [(f'{name}_{i}', shape, [width * i, 1.0 * k, z], IDENTITY) for i in range(3)]
    cylinder = _shape('cylinder')
    bodies += [(f'column_{i}', cylinder, [0.0, 6.0, 0.15 + 0.3 * i], IDENTITY)
               for i in range(4)]
    check_overlaps(bodies, world)


def test_cylinders_and_ellipsoids_nested_crossed_or_in_an_obstacle_are_refused():
    cylinder = primitive_shape('cylinder', [0.05, 1.0])
    across = quat_from_axis_angle([1.0, 0.0, 0.0], math.pi / 2)
    # Two rods crossing at right angles through their middles: out along x, 2 r = 0.1 m.
    assert _depth(cylinder, [0.0, 0.0, 0.0], cylinder, [0.0, 0.0, 0.0], qb=across) == \
        pytest.approx(0.1, abs=SEARCH)
    # Coaxial, overlapping by 2 cm along the axis: flat caps, exactly 0.02 m.
    assert _depth(cylinder, [0.0, 0.0, 0.0], cylinder, [0.0, 0.0, 0.98]) == pytest.approx(
        0.02, abs=SEARCH)
    ell = primitive_shape('ellipsoid', [0.3, 0.2, 0.1])
    small = primitive_shape('ellipsoid', [0.1, 0.05, 0.05])
    # Nested at one centre: at least the ball at the centre, r = 0.05 m in the small one,
    # plus its 0.1 m to the big one's surface.
    assert _depth(small, [0.0, 0.0, 0.0], ell, [0.0, 0.0, 0.0]) >= 0.15 - SEARCH
    rock = obstacle('rock', 'ellipsoid', [0.3, 0.2, 0.1], position_w=[2.0, 0.0, 1.0])
    with pytest.raises(ModelError, match=r'^bodies\.e\.position_w: \[2\.0, 0\.0, 1\.0\] m puts '
                                         r'the body 0\.2 m deep inside obstacles\.rock'):
        check_overlaps([('e', ell, [2.0, 0.0, 1.0], IDENTITY)], StaticWorld(None, (rock,)))


def test_a_mesh_coinciding_with_its_primitive_is_refused():
    mesh = trimesh.creation.box(extents=[0.2, 0.2, 0.2])
    hull = mesh_shape(mesh.vertices, mesh.faces, sdf_cells=16, cache_dir=False)
    box = primitive_shape('box', [0.2, 0.2, 0.2])
    # Exactly 0.2 m; the grid error bound (√3/2) h with h ~ 0.2 / 16 is taken off.
    depth = _depth(hull, [0.0, 0.0, 0.0], box, [0.0, 0.0, 0.0])
    assert 0.2 - 0.5 * math.sqrt(3.0) * 0.2 / 16 * 1.5 <= depth <= 0.2 + SEARCH
    # Resting on it: never above round-off after the error bound is taken off.
    assert _depth(hull, [0.0, 0.0, 0.0], box, [0.0, 0.0, 0.2]) <= ROUND_OFF


def test_pairs_that_never_collide_start_inside_each_other_and_pass_through():
    # Two 0.2 m cubes, the second 0.1 m into the first, moving apart through each other: with
    # the pair in no_collision they start (no overlap check) and never touch (no contact row
    # for them in any step), each moving as a free body would: x = x0 + v t exactly.
    from rbd_ros.core import BodyModel, BodyState, ConfigError
    from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
    box = primitive_shape('box', [0.2, 0.2, 0.2])
    bodies = [WorldBody(name, BodyModel(1.0, np.diag([1.0, 1.0, 1.0]) / 150.0), box)
              for name in ('a', 'b')]
    states = [BodyState(position_w=(0.0, 0.0, 1.0), linear_velocity_w=(1.0, 0.0, 0.0)),
              BodyState(position_w=(0.1, 0.0, 1.0), linear_velocity_w=(-1.0, 0.0, 0.0))]
    with pytest.raises(ModelError, match='deep inside bodies.b'):
        WorldSimulator(bodies, states)
    sim = WorldSimulator(bodies, states, no_collision=[(1, 0)])
    for _ in range(100):
        sim.step(1)
        assert len(sim.contacts) == 0
    # 0.1 s at 1 m/s each way, no gravity: 0.1 m, to the round-off of 100 additions.
    assert abs(sim.body_state(0).position_w[0] - 0.1) < 1e-14
    assert abs(sim.body_state(1).position_w[0] - 0.0) < 1e-14
    with pytest.raises(ConfigError, match=r'^no_collision: pair \(0, 2\) must be two different'):
        WorldSimulator(bodies, states, no_collision=[(0, 2)])


def test_a_body_and_a_static_object_that_never_collide_pass_through_each_other():
    # A 0.2 m cube 0.1 m into a 0.4 m static block, moving through it: with the pair in
    # no_static_collision it starts (no overlap check) and never touches the block (no contact
    # row in any step), moving as a free body: x = x0 + v t; the ground, not skipped, still
    # holds another cube (body 1) resting on it.
    from rbd_ros.core import BodyModel, BodyState, ConfigError
    from rbd_ros.core.contact.simulator import WorldBody, WorldSimulator
    box = primitive_shape('box', [0.2, 0.2, 0.2])
    bodies = [WorldBody(name, BodyModel(1.0, np.diag([1.0, 1.0, 1.0]) / 150.0,
                                        gravity_w=(0.0, 0.0, -9.81 * (name == 'b'))), box)
              for name in ('a', 'b')]
    world = StaticWorld(ground_plane(), (obstacle('block', 'box', [0.4, 0.4, 0.4],
                                                  position_w=(0.0, 0.0, 1.0)),))
    states = [BodyState(position_w=(0.25, 0.0, 1.0), linear_velocity_w=(-1.0, 0.0, 0.0)),
              BodyState(position_w=(2.0, 0.0, 0.1))]
    with pytest.raises(ModelError, match='deep inside obstacles.block'):
        WorldSimulator(bodies, states, world)
    sim = WorldSimulator(bodies, states, world, no_static_collision=[(0, 'block')])
    for _ in range(100):
        sim.step(1)
        assert not np.any(sim.contacts.body_a == 0) and not np.any(sim.contacts.body_b == 0)
    # 0.1 s at 1 m/s, no gravity on a: 0.1 m, to the round-off of 100 additions.
    assert abs(sim.body_state(0).position_w[0] - 0.15) < 1e-14
    # b rests on the ground (its contact rows are there, its height exact): the skip is a's.
    assert np.any(sim.contacts.body_a == 1)
    assert abs(sim.body_state(1).position_w[2] - 0.1) < 1e-12
    with pytest.raises(ConfigError, match=r"^no_static_collision: pair \(0, 'table'\) must"):
        WorldSimulator(bodies, states, world, no_static_collision=[(0, 'table')])
