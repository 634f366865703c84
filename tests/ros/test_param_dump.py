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
``ros2 param dump`` works on every file of ``msg_config/`` (issue 25 item 6).

ros2param's dump verb nests parameter names on '.' into dicts, so a list parameter that is also
the prefix of its items (``bodies`` and ``bodies.a.mass_kg``) crashed it with ``TypeError: list
indices must be integers or slices, not str``. The rule: no declared parameter name is a proper
prefix, at a '.' boundary, of another. It is checked over the parameter table and over what the
node really declares for each file (its ``~/list_parameters`` service); the dump's algorithm,
written out below, runs on the node's real services over DDS, and its output, given back to a
node as a params file, declares the same values.
"""

from pathlib import Path

import pytest
from rbd_ros.bag.recording import open_bag
from rbd_ros.bag.replay import config_from_bag
from rbd_ros.core import ConfigError
from rbd_ros.sim import config as cfg
from rbd_ros.sim import params as sim_params
from rclpy.parameter import parameter_value_to_python
from rclpy.parameter_client import AsyncParameterClient
from ros_probe import Probe
from std_srvs.srv import SetBool
import yaml

REPO = Path(__file__).resolve().parents[2]
FILES = sorted((REPO / 'msg_config').glob('*.yaml'))
BAGS = sorted(p for p in (REPO / 'bags').iterdir() if (p / 'metadata.yaml').is_file())
PARAMETER_SEPARATOR_STRING = '.'  # rclpy.parameter.PARAMETER_SEPARATOR_STRING


def insert_dict(dictionary, key, value):
    """
    Nest ``key`` = ``value`` into ``dictionary``, as ``ros2 param dump`` does.

    Copied from ros2/ros2cli, branch jazzy, ros2param/ros2param/verb/dump.py,
    ``DumpVerb.insert_dict`` (``self`` dropped): a name is split at its first '.', the head
    becomes a dict (if not already there) and the rest is inserted into it. A value already at
    the head that is not a dict (a list parameter that prefixes its items) makes
    ``split[0] in dictionary`` and ``dictionary[split[0]]`` index a list with a str.
    """
    split = key.split(PARAMETER_SEPARATOR_STRING, 1)
    if len(split) > 1:
        if not split[0] in dictionary:
            dictionary[split[0]] = {}
        insert_dict(dictionary[split[0]], split[1], value)
    else:
        dictionary[key] = value


def prefix_clashes(names):
    """Return the pairs ``(a, b)`` of ``names`` where ``a`` is a proper prefix of ``b`` at '.'."""
    names = set(names)
    clashes = []
    for name in names:
        parts = name.split('.')
        for i in range(1, len(parts)):
            head = '.'.join(parts[:i])
            if head in names:
                clashes.append((head, name))
    return sorted(clashes)


def _answered(probe, call, what, tries=6, wait_s=10.0):
    """
    Return the done future of ``call()``, sent again after every ``wait_s`` without an answer.

    A service is "available" once its request reader matched the client; its response writer
    may match the client's reader later, and a response sent before that is lost (a loaded CI
    run waited 30 s for one that never came). The parameter queries read and change nothing,
    so asking again is safe: up to ``tries`` times.
    """
    for attempt in range(tries):
        future = call()
        try:
            probe.wait(future.done, wait_s, what)
            return future
        except AssertionError:
            if attempt == tries - 1:
                raise


def dump(namespace, unpause=False):
    """
    Return ``{node full name: {'ros__parameters': nested}}`` as ``ros2 param dump`` builds it.

    ros2param/ros2param/verb/dump.py (jazzy) ``DumpVerb.main``: ``call_list_parameters`` (api/
    __init__.py: an ``AsyncParameterClient``'s ``list_parameters()``, no prefixes, depth
    unlimited, i.e. recursive), the names sorted, ``call_get_parameters`` for all of them,
    ``get_value`` (``parameter_value_to_python``) of each, then :func:`insert_dict` in that order.
    Also returns the flat ``{name: value}`` read. With ``unpause``, then calls ``~/pause``
    with ``false`` (asked again as the queries are: unpausing twice is unpausing once).
    """
    probe = Probe(namespace, inputs=(), outputs=())
    try:
        client = AsyncParameterClient(probe.node, probe.node_name)
        assert client.wait_for_services(timeout_sec=60.0), 'parameter services of the node'
        future = _answered(probe, client.list_parameters, 'the list_parameters response')
        parameter_names = sorted(future.result().result.names)
        future = _answered(probe, lambda: client.get_parameters(parameter_names),
                           'the get_parameters response')
        parameter_values = [parameter_value_to_python(v) for v in future.result().values]
        if unpause:
            pause = probe.clients['pause']
            probe.wait(pause.service_is_ready, 60.0, 'the pause service')
            future = _answered(probe, lambda: pause.call_async(SetBool.Request(data=False)),
                               'the pause response')
            assert future.result().success, future.result().message
    finally:
        probe.close()
    assert len(parameter_values) == len(parameter_names)
    flat = dict(zip(parameter_names, parameter_values))
    yaml_output = {probe.node_name: {'ros__parameters': {}}}
    for param_name, pval in zip(parameter_names, parameter_values):
        insert_dict(yaml_output[probe.node_name]['ros__parameters'], param_name, pval)
    return yaml_output, flat


def test_the_dump_algorithm_fails_on_a_list_that_prefixes_its_items():
    # What the real CLI did with today's names before the rename (bodies: [a], bodies.a.mass_kg).
    with pytest.raises(TypeError, match='list indices must be integers or slices, not str'):
        out = {}
        for name, value in sorted({'bodies': ['a'], 'bodies.a.mass_kg': 1.0}.items()):
            insert_dict(out, name, value)
    assert prefix_clashes(['bodies', 'bodies.a.mass_kg', 'ground.enabled']) == [
        ('bodies', 'bodies.a.mass_kg')]


def test_no_name_of_the_parameter_table_is_the_prefix_of_another():
    # Every kind of name: inputs and obstacles of one body; a world's bodies and their inputs.
    obstacle = {'obstacle_names': ['o'], 'obstacles.o.dimensions_m': [0.1, 0.1, 0.1],
                'obstacles.o.position': [5.0, 0.0, 0.0]}
    one = cfg.NodeConfig.from_parameters({'wrench_input_names': ['x'], **obstacle})
    world = cfg.NodeConfig.from_parameters({
        'body_names': ['b'], 'bodies.b.wrench_input_names': ['y'], **obstacle})
    for config in (one, world):
        names = [spec.name for spec in config.all_specs()]
        assert len(names) == len(set(names))
        assert prefix_clashes(names) == []
    assert 'wrench_inputs.x.topic' in {s.name for s in one.all_specs()}
    assert {'bodies.b.wrench_inputs.y.topic', 'bodies.b.mass_kg', 'obstacles.o.shape'} <= {
        s.name for s in world.all_specs()}


@pytest.mark.parametrize('old, new, value', [
    ('bodies', 'body_names', ['a']),
    ('obstacles', 'obstacle_names', ['wall']),
    ('wrench_inputs', 'wrench_input_names', ['left']),
    ('bodies.a.wrench_inputs', 'bodies.a.wrench_input_names', ['left']),
])
def test_an_old_list_name_is_refused_naming_the_new_one(old, new, value):
    with pytest.raises(ConfigError) as info:
        cfg.NodeConfig.from_parameters({old: value})
    assert str(info.value) == (
        f'parameter {old} = {value!r}: renamed to {new} (a list is never the prefix of its '
        f'items; the items {old}.<name>.* keep their names)')
    assert sim_params.recorded_parameters({old: value, 'mass_kg': 2.0}) == {
        new: value, 'mass_kg': 2.0}


#: Re-recorded after the rename (stack_knocked: 2026-12-04, the friction warm start;
#: floor_world_push and l_block_bin: 2026-12-07, the Coulomb cone's Newton step) or newer
#: than it (robot_pendulum, door_world, arm_table_sweep, arm_trajectory), so recorded with
#: today's names.
NEW_NAME_BAGS = ('arm_table_sweep', 'arm_trajectory', 'door_world', 'floor_world_push',
                 'l_block_bin', 'robot_pendulum', 'stack_knocked')
OLD_NAME_BAGS = [p for p in BAGS if p.name not in NEW_NAME_BAGS]


@pytest.mark.parametrize('bag_dir', OLD_NAME_BAGS, ids=[p.name for p in OLD_NAME_BAGS])
def test_a_bag_recorded_with_the_old_names_reads_under_the_new_ones(bag_dir):
    # These bags were recorded before the rename (tests/recording/test_reference_bags.py
    # replays them bit-exact); the stored record keeps its names (the older bags predate bodies
    # and obstacles: absent means []), the configuration gets today's.
    bag = open_bag(str(bag_dir))
    assert 'wrench_inputs' in bag.config and 'wrench_input_names' not in bag.config
    params = config_from_bag(bag).to_parameters()
    assert not {name for name in params if sim_params.new_parameter_name(name)}
    for old, new in sim_params.RENAMED_PARAMETERS.items():
        assert params[new] == bag.config.get(old, []), new
    assert prefix_clashes(params) == []


@pytest.mark.parametrize('name', NEW_NAME_BAGS)
def test_a_bag_recorded_with_the_new_names_reads_as_recorded(name):
    bag = open_bag(str(REPO / 'bags' / name))
    assert 'body_names' in bag.config and not {
        old for old in sim_params.RENAMED_PARAMETERS if old in bag.config}
    params = config_from_bag(bag).to_parameters()
    for new in sim_params.RENAMED_PARAMETERS.values():
        assert params[new] == bag.config.get(new, []), new
    assert prefix_clashes(params) == []


def test_an_old_params_file_stops_the_node_with_one_line(start_node, tmp_path):
    node = start_node({'bodies': ['a'], 'bodies.a.shape': 'sphere'})
    assert node.wait(120) == 2, node.stderr
    assert 'parameter bodies = [' in node.stderr and 'renamed to body_names' in node.stderr
    assert len(node.stderr.strip().splitlines()) == 1, node.stderr


#: Each file also runs: started paused (its parameters are read while nothing moves), then let
#: go, it steps 0.05 s of sim as fast as it can and exits 0 by its duration. (That was
#: test_node_lifecycle.py's check that every msg_config/ file is valid, a start of its own.)
RUN = {'start_paused': True, 'duration_s': 0.05, 'real_time_factor': 0.0}


@pytest.mark.parametrize('path', FILES, ids=[p.stem for p in FILES])
def test_ros2_param_dump_nests_every_file_and_the_dump_loads_back(start_node, tmp_path, path):
    first = start_node(RUN, params_file=path, namespace=True)
    dumped, flat = dump(first.namespace, unpause=True)
    assert first.wait(60) == 0, (path.name, first.stderr)
    assert prefix_clashes(flat) == [], f'{path.name}: a name is the prefix of another'
    assert any(isinstance(v, dict) for v in next(iter(dumped.values()))['ros__parameters']
               .values()), 'nothing nested: the check would be vacuous'
    # The dump as the verb prints it (yaml.dump), given as the params file of a second node of
    # the same full name (its qos_overrides.<absolute topic>.* names hold the namespace), the
    # first one gone (stop() waited for its exit).
    dump_file = tmp_path / f'{path.stem}_dump.yaml'
    dump_file.write_text(yaml.dump(dumped, default_flow_style=False))
    second = start_node(params_file=dump_file, namespace=first.namespace)
    _, again = dump(first.namespace)
    assert second.stop() == 0, second.stderr
    assert 'ignoring unknown parameter' not in second.stderr, second.stderr
    # Exact: the same values go through YAML text and back (yaml.dump writes floats with repr).
    assert again == flat
