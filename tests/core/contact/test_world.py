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
Materials and their pair rule, the static world, and the start-up overlap check.

Depths are compared to ``ROUND_OFF = 1e-12`` m: a rotation of unit-size points and a closed-form
φ are a few dozen float64 operations (~1e-16 relative each).
"""

import math

import numpy as np
import pytest

from rbd_ros.core.contact import (check_overlaps, ground_plane, Material, mesh_shape, obstacle,
                                  penetration_depth, primitive_shape, StaticObject, StaticWorld,
                                  validate_material)
from rbd_ros.core.errors import ModelError
from rbd_ros.core.rotations import quat_from_axis_angle, quat_to_matrix
import trimesh

ROUND_OFF = 1e-12
IDENTITY = (1.0, 0.0, 0.0, 0.0)


def test_pair_rule_is_geometric_mean_friction_and_larger_restitution():
    rubber = Material(1.0, 0.8)
    steel = Material(0.25, 0.5)
    ice = Material(0.0, 0.1)
    pair = rubber.combine(steel)
    assert pair.friction == pytest.approx(0.5, abs=ROUND_OFF)
    assert pair.restitution == 0.8
    assert steel.combine(rubber) == pair  # symmetric
    assert steel.combine(steel) == steel  # a material meeting itself keeps its values
    assert rubber.combine(ice).friction == 0.0  # ice makes any pair frictionless


@pytest.mark.parametrize('friction, restitution, needle', [
    (-0.1, 0.0, 'obstacles.ramp.friction: -0.1 (dimensionless) must be finite and >= 0'),
    (float('nan'), 0.0, 'obstacles.ramp.friction: nan (dimensionless)'),
    (0.5, 1.5, 'obstacles.ramp.restitution: 1.5 (dimensionless) must be in [0, 1]'),
    (0.5, -0.01, 'obstacles.ramp.restitution: -0.01 (dimensionless) must be in [0, 1]'),
    (True, 0.0, 'obstacles.ramp.friction: True is not a number'),
])
def test_bad_materials_are_refused_with_the_field_named(friction, restitution, needle):
    with pytest.raises(ModelError) as info:
        validate_material(friction, restitution, field='obstacles.ramp.')
    assert str(info.value).startswith(needle)
    with pytest.raises(ModelError):
        Material(friction, restitution)


def test_obstacle_errors_name_the_object_and_field(tmp_path):
    with pytest.raises(ModelError, match=r'^obstacles\.ramp\.dimensions_m: \[0\.0, 1\.0, 1\.0\] m '
                                         r"for shape 'box' \[x, y, z\]: x = 0\.0 m must be"):
        obstacle('ramp', 'box', [0.0, 1.0, 1.0])
    with pytest.raises(ModelError, match=r'^obstacles\.ramp\.position_w: \[0\.0, nan, 0\.0\] m'):
        obstacle('ramp', 'box', [1.0, 1.0, 1.0], position_w=[0.0, float('nan'), 0.0])
    with pytest.raises(ModelError, match=r'^obstacles\.ramp\.orientation_wb.*norm 0\.0'):
        obstacle('ramp', 'box', [1.0, 1.0, 1.0], orientation_wb=[0.0, 0.0, 0.0, 0.0])
    with pytest.raises(ModelError, match=r"^obstacles\.rock\.mesh_path: '.*rock\.obj' does not"):
        obstacle('rock', 'mesh', mesh_path=tmp_path / 'rock.obj')
    with pytest.raises(ModelError, match=r"^obstacles: name '2nd' must be an identifier"):
        obstacle('2nd', 'sphere', [1.0])
    with pytest.raises(ModelError, match=r'^ground\.normal: \[0\.0, 0\.0, 0\.0\]'):
        ground_plane([0.0, 0.0, 0.0])


def test_static_world_holds_one_ground_and_uniquely_named_obstacles():
    ground = ground_plane([0.0, 0.0, 3.0], -0.5, Material(0.8, 0.1))
    np.testing.assert_allclose(ground.shape.params[:4], [0.0, 0.0, 1.0, -0.5])
    wall = obstacle('wall', 'box', [0.2, 4.0, 2.0], position_w=[2.0, 0.0, 1.0])
    ball = obstacle('ball', 'sphere', [0.3], position_w=[-2.0, 0.0, 0.3], restitution=0.9)
    world = StaticWorld(ground, (wall, ball))
    labels = [label for label, _ in world.objects()]
    assert labels == ['ground', 'obstacles.wall', 'obstacles.ball']
    assert world == StaticWorld(ground, [wall, ball])
    with pytest.raises(ModelError, match=r'^obstacles\.wall: the name is used twice'):
        StaticWorld(ground, (wall, wall))
    with pytest.raises(ModelError, match=r'^obstacles\.floor2\.shape: a plane'):
        StaticWorld(ground, (StaticObject('floor2', ground.shape),))
    with pytest.raises(ModelError, match=r"^ground: a 'box' object; the ground must be a plane"):
        StaticWorld(wall)


def test_obstacle_pose_is_normalised_and_read_only():
    q = np.array([2.0, 0.0, 0.0, 0.0])
    rock = obstacle('rock', 'sphere', [0.5], orientation_wb=q)
    np.testing.assert_array_equal(rock.orientation_wb, IDENTITY)
    with pytest.raises(ValueError):
        rock.position_w[0] = 1.0


def test_penetration_depth_of_a_box_into_the_ground_and_a_tilted_box():
    ground = ground_plane()
    box = primitive_shape('box', [0.2, 0.2, 0.2])
    depth, point = penetration_depth(box, [0.0, 0.0, 0.05], IDENTITY, ground.shape,
                                     ground.position_w, ground.orientation_wb)
    # The bottom face is at z = -0.05: every point of it is 0.05 m deep.
    assert depth == pytest.approx(0.05, abs=ROUND_OFF)
    assert point[2] == pytest.approx(-0.05, abs=ROUND_OFF)
    # Tilted 45° about x, centre at height 0.1: the lowest edge is at 0.1 - 0.1 sqrt(2).
    q = quat_from_axis_angle([1.0, 0.0, 0.0], math.pi / 4)
    depth, _ = penetration_depth(box, [0.0, 0.0, 0.1], q, ground.shape, ground.position_w,
                                 ground.orientation_wb)
    assert depth == pytest.approx(0.1 * math.sqrt(2.0) - 0.1, abs=ROUND_OFF)
    # Two unit spheres whose centres are 1.5 m apart overlap by 0.5 m.
    ball = primitive_shape('sphere', [1.0])
    depth, _ = penetration_depth(ball, [0.0, 0.0, 0.0], IDENTITY, ball, [1.5, 0.0, 0.0],
                                 IDENTITY)
    assert depth == pytest.approx(0.5, abs=ROUND_OFF)
    far, _ = penetration_depth(ball, [0.0, 0.0, 0.0], IDENTITY, ball, [2.5, 0.0, 0.0],
                               IDENTITY)
    assert far == -math.inf


def test_a_small_body_wholly_inside_a_big_one_is_found():
    big = primitive_shape('box', [2.0, 2.0, 2.0])
    small = primitive_shape('sphere', [0.1])
    depth, _ = penetration_depth(small, [0.0, 0.0, 0.0], IDENTITY, big, [0.0, 0.0, 0.0],
                                 IDENTITY)
    # Pushing the sphere out of the box takes the centre's 1.0 m to the nearest face plus its
    # radius 0.1 m (r − φ_box(c)), whichever body is named first.
    assert depth == pytest.approx(1.1, abs=ROUND_OFF)
    swapped, _ = penetration_depth(big, [0.0, 0.0, 0.0], IDENTITY, small, [0.0, 0.0, 0.0],
                                   IDENTITY)
    assert swapped == depth


@pytest.mark.parametrize('shape, dimensions, inner_m', [
    ('box', [0.2, 0.2, 0.2], 0.1), ('sphere', [0.5], 0.5), ('capsule', [0.1, 0.4], 0.1),
    ('cylinder', [0.2, 0.1], 0.05), ('ellipsoid', [0.3, 0.2, 0.1], 0.1)])
def test_coincident_identical_bodies_overlap_by_their_inner_diameter(shape, dimensions, inner_m):
    # Issue 25 item 7: on coincident surfaces every surface point reads φ = 0, so the surface
    # test found no overlap. Separating two identical convex bodies at one pose takes a shift
    # of twice the distance from the origin to the nearest face (the thinner way out).
    body = primitive_shape(shape, dimensions)
    q = quat_from_axis_angle([0.0, 1.0, 0.0], 0.3)
    depth, point = penetration_depth(body, [1.0, 2.0, 3.0], q, body, [1.0, 2.0, 3.0], q)
    assert depth == pytest.approx(2.0 * inner_m, abs=ROUND_OFF)
    # The point named is inside the body (for coincident cores any point of them is).
    inside = quat_to_matrix(q).T @ (point - np.array([1.0, 2.0, 3.0]))
    assert body.signed_distance(inside)[0] <= ROUND_OFF
    with pytest.raises(ModelError, match=r'^bodies\.a\.position_w: \[1\.0, 2\.0, 3\.0\] m puts '
                                         r'the body .* deep inside bodies\.b'):
        check_overlaps([('a', body, [1.0, 2.0, 3.0], q), ('b', body, [1.0, 2.0, 3.0], q)])


def test_check_overlaps_refuses_bodies_deep_inside_and_accepts_resting_ones():
    ground = ground_plane()
    ramp = obstacle('ramp', 'box', [2.0, 1.0, 0.5], position_w=[5.0, 0.0, 0.25])
    world = StaticWorld(ground, (ramp,))
    box = primitive_shape('box', [0.2, 0.2, 0.2])
    resting = [('crate', box, [0.0, 0.0, 0.1], IDENTITY),
               ('lid', box, [0.0, 0.0, 0.3], IDENTITY),
               ('on_ramp', box, [5.0, 0.0, 0.6], IDENTITY)]
    check_overlaps(resting, world)  # touching within round-off: accepted
    with pytest.raises(ModelError, match=r'^bodies\.crate\.position_w: \[0\.0, 0\.0, 0\.05\] m '
                                         r'puts the body 0\.05 m deep inside ground'):
        check_overlaps([('crate', box, [0.0, 0.0, 0.05], IDENTITY)], world)
    with pytest.raises(ModelError, match=r'^bodies\.crate\.position_w: .* deep inside '
                                         r'obstacles\.ramp'):
        check_overlaps([('crate', box, [5.0, 0.0, 0.4], IDENTITY)], world)
    with pytest.raises(ModelError, match=r'^bodies\.crate\.position_w: .* 0\.1 m deep inside '
                                         r'bodies\.lid'):
        check_overlaps([('crate', box, [0.0, 0.0, 0.1], IDENTITY),
                        ('lid', box, [0.0, 0.0, 0.2], IDENTITY)], world)
    # The tolerance admits a shallow overlap and is itself validated.
    check_overlaps([('crate', box, [0.0, 0.0, 0.0995], IDENTITY)], world, tolerance_m=1e-3)
    with pytest.raises(ModelError, match=r"^bodies: name 'my crate' must be an identifier"):
        check_overlaps([('my crate', box, [0.0, 0.0, 1.0], IDENTITY)], world)
    with pytest.raises(ModelError, match=r'^bodies\.crate\.position_w: \[0\.0, 1\.0\] is not 3'):
        check_overlaps([('crate', box, [0.0, 1.0], IDENTITY)], world)
    with pytest.raises(ModelError, match=r'^tolerance_m: -1\.0'):
        check_overlaps([], world, tolerance_m=-1.0)


def test_check_overlaps_allows_for_the_mesh_grid_error(tmp_path):
    mesh = trimesh.creation.box(extents=[0.2, 0.2, 0.2])
    hull = mesh_shape(mesh.vertices, mesh.faces, sdf_cells=8, cache_dir=False)
    ball = primitive_shape('sphere', [0.1])
    # A ball resting on the mesh box: the exact gap is 0, the grid is within (√3/2) h.
    check_overlaps([('hull', hull, [0.0, 0.0, 0.0], IDENTITY),
                    ('ball', ball, [0.0, 0.0, 0.2], IDENTITY)])
    with pytest.raises(ModelError, match=r'^bodies\.hull\.position_w: .* deep inside '
                                         r'bodies\.ball'):
        check_overlaps([('hull', hull, [0.0, 0.0, 0.0], IDENTITY),
                        ('ball', ball, [0.0, 0.0, 0.1], IDENTITY)])


def test_check_overlaps_finds_the_one_overlap_among_many_bodies_in_any_order():
    # 400 boxes on a 0.3 m grid, none touching; the last one is moved 5 cm into the first.
    # The bounding-ball culling (all pairs at once) must keep that pair however far apart
    # their indices are, and name the first body of the pair, with the depth in m.
    box = primitive_shape('box', [0.2, 0.2, 0.2])
    bodies = [(f'b{k}', box, [0.3 * (k % 20), 0.3 * (k // 20), 0.1], IDENTITY)
              for k in range(400)]
    check_overlaps(bodies, StaticWorld(ground_plane()))
    bodies[-1] = ('b399', box, [0.15, 0.0, 0.1], IDENTITY)
    with pytest.raises(ModelError, match=r'^bodies\.b0\.position_w: \[0\.0, 0\.0, 0\.1\] m puts '
                                         r'the body 0\.05 m deep inside bodies\.b399'):
        check_overlaps(bodies, StaticWorld(ground_plane()))
