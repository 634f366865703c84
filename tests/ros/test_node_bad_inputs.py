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
Bad inputs at start-up give one bounded line naming the parameter (issue 31 items 4 and 6).

Each case starts ``rigid_body_node`` with a real parameter file (written to ``tmp_path``) the way
a user does, with no ament index (``AMENT_PREFIX_PATH`` unset: the documented ``.venv`` way),
and expects exit 2 and one stderr line that names the parameter, its value and why.
"""

import os

from conftest import REPO
import pytest
from rbd_ros.bag.recording import open_bag
from rbd_ros.sim import params as sim_params
from rbd_ros.sim.config import NodeConfig
import yaml

L_BLOCK = 'package://rbd_ros/msg_config/meshes/l_block.stl'
DEFAULT = REPO / 'msg_config' / 'default.yaml'  # the box on the floor, a contact integrator
STACK = REPO / 'msg_config' / 'stack.yaml'
PENDULUM_URDF = REPO / 'msg_config' / 'urdf' / 'pendulum.urdf'
MAX_LINE = 400  # characters: a refusal is one readable line, however long the values


def _obstacle(**fields):
    """One box obstacle 'o' well below the floor (clear of the body), plus ``fields``."""
    return {'obstacle_names': ['o'], 'obstacles.o.dimensions_m': [1.0, 1.0, 1.0],
            'obstacles.o.position': [0.0, 0.0, -5.0],
            **{f'obstacles.o.{k}': v for k, v in fields.items()}}


def _fifo(tmp):
    path = tmp / 'mesh.fifo'
    os.mkfifo(path)
    return str(path)


def _sparse(tmp):
    path = tmp / 'huge.stl'
    with open(path, 'wb') as f:
        f.truncate(sim_params.MAX_MESH_FILE_BYTES + 1)  # sparse: no disk, no time
    return str(path)


def _long_name(tmp, chars=233):
    """Return a world of one body whose ``<name>/contact_wrench`` is past rcl's 247."""
    name = 'n' * chars
    return {'body_names': [name], f'bodies.{name}.initial_position': [0.0, 0.0, 0.5],
            'ground.enabled': True, 'record_path': str(tmp / 'bag')}


def _long_robot_name(tmp, chars=229):
    """Return a pendulum robot whose ``<name>/robot_description`` is past rcl's 247."""
    name = 'r' * chars
    return {'robot_names': [name], f'robots.{name}.urdf_path': str(PENDULUM_URDF),
            'gravity': [0.0, 0.0, -9.81]}


def _long_group_name(tmp, chars=231):
    """Return a pendulum with a command group whose ``<name>/joint_trajectory`` is too long."""
    name = 'g' * chars
    return {'robot_names': ['p'], 'robots.p.urdf_path': str(PENDULUM_URDF),
            'command_group_names': [name], f'command_groups.{name}.robot': 'p',
            f'command_groups.{name}.joints': ['pivot'],
            f'command_groups.{name}.interface': 'position'}


def _stack_with_spin(tmp):
    params = yaml.safe_load(STACK.read_text())['/**']['ros__parameters']
    return {**params, 'bodies.middle.initial_angular_velocity': [1e200, 0.0, 0.0]}


CASES = [  # (base params file, params from tmp_path, what the one line must contain)
    (None, lambda tmp: {'mesh_path': 'package://no_such_pkg/m.stl'},
     ["parameter mesh_path = 'package://no_such_pkg/m.stl'", "package 'no_such_pkg'"]),
    (DEFAULT, lambda tmp: {**_obstacle(shape='mesh', mesh_path='package://no_such_pkg/m.stl'),
                           'obstacles.o.dimensions_m': []},
     ["parameter obstacles.o.mesh_path = 'package://no_such_pkg/m.stl'"]),
    (DEFAULT, lambda tmp: {**_obstacle(mesh_path=str(tmp / 'missing.stl')),
                           'record_path': str(tmp / 'bag')},
     ['parameter obstacles.o.mesh_path', 'missing.stl', "not used by shape 'box'"]),
    (DEFAULT, lambda tmp: {**_obstacle(mesh_path=_fifo(tmp)), 'record_path': str(tmp / 'bag')},
     ['parameter obstacles.o.mesh_path', 'mesh.fifo', "not used by shape 'box'"]),
    (DEFAULT, lambda tmp: {**_obstacle(mesh_path='/dev/zero'), 'record_path': str(tmp / 'bag')},
     ["parameter obstacles.o.mesh_path = '/dev/zero'", "not used by shape 'box'"]),
    (DEFAULT, lambda tmp: {**_obstacle(shape='mesh', mesh_path='/dev/zero'),
                           'obstacles.o.dimensions_m': [], 'record_path': str(tmp / 'bag')},
     ["parameter obstacles.o.mesh_path = '/dev/zero'", 'not a regular file']),
    (DEFAULT, lambda tmp: _obstacle(mesh_scale=[0.0, -1.0, 1.0]),
     ['parameter obstacles.o.mesh_scale = [0.0, -1.0, 1.0]']),
    (DEFAULT, lambda tmp: _obstacle(shape='mesh', mesh_path=L_BLOCK),
     ['parameter obstacles.o.dimensions_m = [1.0, 1.0, 1.0] m', "not used by shape 'mesh'"]),
    (DEFAULT, lambda tmp: {**_obstacle(shape='mesh', mesh_path=_fifo(tmp)),
                           'obstacles.o.dimensions_m': []},
     ['parameter obstacles.o.mesh_path', 'mesh.fifo', 'not a regular file']),
    (DEFAULT, lambda tmp: {**_obstacle(shape='mesh', mesh_path=_sparse(tmp)),
                           'obstacles.o.dimensions_m': []},
     ['parameter obstacles.o.mesh_path', 'huge.stl',
      f'limit of {sim_params.MAX_MESH_FILE_BYTES} bytes']),
    (None, lambda tmp: {'wrench_input_names': ['a'], 'wrench_inputs.a.topic': 'drag'},
     ["parameter wrench_inputs.a.topic = 'drag'", "drag input 'drag'"]),
    (None, lambda tmp: {'wrench_input_names': ['a'], 'wrench_inputs.a.topic': '/clicked_point'},
     ["parameter wrench_inputs.a.topic = '/clicked_point'", "drag input 'clicked_point'"]),
    (None, lambda tmp: {'shape': 'box', 'dimensions_m': [1e300, 1.0, 1.0]},
     ['parameter dimensions_m = [1e+300, 1.0, 1.0] m', f'at most {sim_params.MAX_SIZE:g} m']),
    (None, lambda tmp: {'mesh_path': L_BLOCK, 'mesh_scale': [1e100, 1e100, 1e100]},
     ['parameter mesh_scale = [1e+100, 1e+100, 1e+100]']),
    (None, lambda tmp: {'body_names': [f'b{i}' for i in range(15000)]},
     ['parameter body_names = ', f'15000 bodies exceed the limit of {sim_params.MAX_BODIES}']),
    (None, lambda tmp: {'obstacle_names': [f'o{i}' for i in range(60_000)]},
     ['parameter obstacle_names = ', f'more than {sim_params.MAX_ARRAY_ITEMS} items']),
    (None, _long_name,  # '/' + 233 + '/contact_wrench' = 249 characters resolved
     ["parameter body_names = ['nnnn", '(233 characters)', "nnnn/contact_wrench' 249 "
      "characters long, past rcl's limit of 247"]),
    (None, _long_robot_name,  # '/' + 229 + '/robot_description' = 248 characters resolved
     ["parameter robot_names = ['rrrr", "robot 0 makes the topic '...", "rrrr/robot_description' "
      "248 characters long, past rcl's limit of 247"]),
    (None, _long_group_name,  # '/' + 231 + '/joint_trajectory' = 249 characters resolved
     ["parameter command_group_names = ['gggg", "command group 0 makes the topic '...",
      "gggg/joint_trajectory' 249 characters long, past rcl's limit of 247"]),
    (None, lambda tmp: {'wrench_input_names': ['a'], 'wrench_inputs.a.topic': 't' * 250},
     ["parameter wrench_inputs.a.topic = 'ttt", '(250 characters)', 'past rcl']),
    (None, _stack_with_spin,
     ['parameter bodies.middle.initial_angular_velocity = [1e+200, 0.0, 0.0] rad/s',
      'not finite']),
]


def test_a_namespace_too_long_for_the_node_names_it(start_node):
    # 231 + 2 slashes + rigid_body_node/describe_parameters (35) = 268 > 247 characters
    node = start_node(namespace='/' + 'n' * 231)
    assert node.wait(120) == 2, node.stderr
    lines = [line for line in node.stderr.splitlines() if line.strip()]
    assert len(lines) == 1 and len(lines[0]) <= MAX_LINE, lines
    assert "name or namespace (-r __ns:=...) makes '...nnnn/rigid_body_node/" in lines[0]
    assert '(268 characters)' in lines[0] and "rcl's limit is 247" in lines[0], lines[0]


@pytest.fixture
def no_ament_index(monkeypatch):
    """Run as from the .venv: no ament index (the node subprocesses inherit os.environ)."""
    monkeypatch.delenv('AMENT_PREFIX_PATH', raising=False)


@pytest.mark.parametrize('base, params, texts', CASES, ids=[str(i) for i in range(len(CASES))])
def test_a_bad_input_is_one_bounded_line_naming_it(no_ament_index, start_node, tmp_path, base,
                                                   params, texts):
    node = start_node(params(tmp_path), params_file=base)
    assert node.wait(120) == 2, node.stderr  # 120 s: a loaded machine, a world's first step
    lines = [line for line in node.stderr.splitlines() if line.strip()]
    assert len(lines) == 1, lines
    assert lines[0].startswith('rigid_body_node: ') and len(lines[0]) <= MAX_LINE, lines[0]
    for text in texts:
        assert text in lines[0], lines[0]
    assert not (tmp_path / 'bag').exists()  # refused before the recorder opened anything


def test_package_urls_resolve_without_an_ament_index(no_ament_index, start_node, tmp_path):
    # The README's own example, for a body and for an obstacle, in a source checkout.
    obstacle = {**_obstacle(shape='mesh', mesh_path=L_BLOCK), 'obstacles.o.dimensions_m': []}
    config = NodeConfig.from_parameters({'mesh_path': L_BLOCK, 'ground.enabled': True,
                                         'integrator': 'midpoint_cayley',
                                         'initial_position': [0.0, 0.0, 0.5], **obstacle})
    assert config.collision_shape is not None and len(config.static_world.obstacles) == 1
    # Through the node, recorded: the mesh is embedded under its package:// name.
    node = start_node({'mesh_path': L_BLOCK, 'duration_s': 0.01, 'real_time_factor': 0.0,
                       'record_path': str(tmp_path / 'bag')},
                      params_file=REPO / 'msg_config' / 'l_block_bin.yaml')
    assert node.wait(120) == 0, node.stderr
    mesh = (REPO / 'msg_config' / 'meshes' / 'l_block.stl').read_bytes()
    assert open_bag(str(tmp_path / 'bag')).attachments() == {L_BLOCK: mesh}
