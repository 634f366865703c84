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
The package as users install it: dependencies declared, one version, colcon build, launch file.

``colcon build`` of a copy of the package, then start the installed executable. This is what a
Jazzy user does (``colcon build``; ``source install/setup.bash``;
``ros2 run rbd_ros rigid_body_node``): ``ros2 run`` executes
``<prefix>/lib/rbd_ros/rigid_body_node`` with the install's site-packages on PYTHONPATH, which is
what the test reproduces without ros2cli (not in the PyPI wheels). A pip user's install is
reproduced in a new venv (ROS wheels, then the package, not editable).
"""

import ast
import importlib.metadata
import os
from pathlib import Path
import re
import shutil
import subprocess
import sys
import time
from xml.etree import ElementTree

from conftest import FIRST_START_S
import pytest
from rbd_ros.core.contact.mesh_shapes import load_mesh
from rbd_ros.core.errors import ModelError
from rbd_ros.msgs import outputs
from rbd_ros.ros import endpoints
from rbd_ros.sim import drag
from rbd_ros.sim.params import PARAMETERS_BY_NAME
import rclpy
from rclpy.context import Context
from rclpy.qos import DurabilityPolicy
import yaml

REPO = Path(__file__).resolve().parents[1]
PACKAGE_FILES = ('package.xml', 'setup.py', 'setup.cfg', 'resource', 'rbd_ros', 'msg_config',
                 'launch', 'rviz')
PACKAGE_XML = ElementTree.parse(REPO / 'package.xml').getroot()
EXEC_DEPENDS = {e.text.strip() for e in PACKAGE_XML.iter('exec_depend')}
# Imported by rbd_ros, provided by ROS (rosdep keys = package names, or the ros-jazzy-* wheels),
# so not in install_requires but exec_depends of package.xml.
ROS_PACKAGES = ('ament_index_python', 'builtin_interfaces', 'diagnostic_msgs', 'geometry_msgs',
                'nav_msgs', 'rcl_interfaces', 'rclpy', 'rosgraph_msgs', 'sensor_msgs', 'std_msgs',
                'std_srvs', 'tf2_msgs', 'trajectory_msgs', 'visualization_msgs')
# Every other module rbd_ros imports → its key in ros/rosdistro rosdep/python.yaml (each key
# checked to exist there; mcap has none of its own: mcap-ros2-support's pip package brings it).
ROSDEP_KEYS = {'numpy': 'python3-numpy', 'numba': 'python3-numba', 'yaml': 'python3-yaml',
               'matplotlib': 'python3-matplotlib', 'mpl_toolkits': 'python3-matplotlib',
               'trimesh': 'python3-trimesh-pip', 'mcap': 'mcap-ros2-support',
               'mcap_ros2': 'mcap-ros2-support', 'rosbags': 'python3-rosbags-pip',
               'yourdfpy': 'python3-yourdfpy-pip', 'lxml': 'python3-lxml', 'xacro': 'xacro'}
LAUNCH_ARGUMENTS = {'params_file', 'namespace', 'record_path', 'use_sim_time', 'rviz'}


def _copy_package(destination):
    """Copy the files of the package (what colcon or pip sees) to ``destination``."""
    destination.mkdir(parents=True)
    for name in PACKAGE_FILES:
        path = REPO / name
        if path.is_dir():
            shutil.copytree(path, destination / name,
                            ignore=shutil.ignore_patterns('__pycache__', '*.pyc'))
        else:
            shutil.copy2(path, destination / name)
    return destination


def _clean_env():
    """Return the environment without PYTHONPATH (the worktree must not leak in)."""
    return {k: v for k, v in os.environ.items() if k != 'PYTHONPATH'}


def _modules():
    """Return the dotted names of every module of rbd_ros (from the source tree)."""
    names = []
    for path in sorted((REPO / 'rbd_ros').rglob('*.py')):
        parts = path.relative_to(REPO).with_suffix('').parts
        names.append('.'.join(parts[:-1] if parts[-1] == '__init__' else parts))
    return names


def _imported_top_level_names():
    """Return ``{top-level module: [files importing it]}`` for every import in rbd_ros."""
    found = {}
    for path in sorted((REPO / 'rbd_ros').rglob('*.py')):
        for item in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(item, ast.Import):
                names = [alias.name for alias in item.names]
            elif isinstance(item, ast.ImportFrom) and item.level == 0:
                names = [item.module]
            else:
                continue
            for name in names:
                found.setdefault(name.split('.')[0], []).append(str(path.relative_to(REPO)))
    return {name: files for name, files in found.items()
            if name not in sys.stdlib_module_names and name != 'rbd_ros'}


def _requirement_name(text):
    """Return the normalised distribution name of a requirement string (PEP 503)."""
    return re.sub(r'[-_.]+', '-', re.match(r'[A-Za-z0-9_.-]+', text).group(0)).lower()


def _setup_py(*args, cwd=REPO):
    """Run ``setup.py`` with ``args``; return its stdout."""
    run = subprocess.run([sys.executable, 'setup.py', *args], cwd=cwd, env=_clean_env(),
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 0, run.stdout + run.stderr
    return run.stdout


def _install_requires():
    """Return ``{normalised distribution name: requirement}`` of setup.py install_requires."""
    tree = ast.parse((REPO / 'setup.py').read_text())
    (assign,) = [n for n in tree.body if isinstance(n, ast.Assign)
                 and [t.id for t in n.targets if isinstance(t, ast.Name)] == ['install_requires']]
    return {_requirement_name(r): r for r in ast.literal_eval(assign.value)}


def _pins():
    """Return ``{normalised distribution name: pinned version}`` of .ci/requirements.txt."""
    pins = {}
    for line in (REPO / '.ci' / 'requirements.txt').read_text().splitlines():
        match = re.match(r'([A-Za-z0-9_.-]+)(\[[^]]*\])?==(\S+)', line)
        if match:
            pins[_requirement_name(match.group(1))] = (match.group(0), match.group(3))
    return pins


def test_every_third_party_import_is_declared_for_pip_and_rosdep():
    imported = _imported_top_level_names()
    requires = _install_requires()
    distributions = importlib.metadata.packages_distributions()
    unknown = sorted(set(imported) - set(ROS_PACKAGES) - set(ROSDEP_KEYS))
    assert not unknown, f'imports with no rosdep key in this test: {unknown}'
    for name in ROS_PACKAGES:
        assert name in EXEC_DEPENDS, f'{name} (ROS) is not an exec_depend of package.xml'
    for name, files in sorted(imported.items()):
        if name in ROS_PACKAGES:
            continue
        dists = {_requirement_name(d) for d in distributions.get(name, ())}
        assert dists, f'{name} (imported by {files[0]}) is not installed here'
        assert dists & set(requires), \
            f'{name} (imported by {files[0]}; {sorted(dists)}) is not in install_requires'
        assert ROSDEP_KEYS[name] in EXEC_DEPENDS, \
            f'{name}: rosdep key {ROSDEP_KEYS[name]} is not an exec_depend of package.xml'
    # trimesh reads an STL it cannot parse as binary as text through charset_normalizer, an
    # import hidden from the AST walk: declared by hand (see the random-bytes STL test below).
    assert 'charset-normalizer' in requires


def test_install_requires_lower_bounds_are_the_tested_pins():
    pins = _pins()
    for name, requirement in _install_requires().items():
        assert name in pins, f'{requirement}: no pin in .ci/requirements.txt (untested)'
        assert requirement == f'{requirement.split(">=")[0]}>={pins[name][1]}', \
            f'{requirement}: lower bound is not the tested pin {pins[name][0]}'


def test_random_bytes_stl_is_a_one_line_error_naming_mesh_path(tmp_path):
    # Random bytes are neither a binary STL (wrong length) nor text: trimesh then guesses the
    # encoding with charset_normalizer, which must be installed (it once was not, and the error
    # was "No module named 'charset_normalizer'").
    rng = __import__('random').Random(25)
    for i in range(5):
        path = tmp_path / f'noise_{i}.stl'
        path.write_bytes(bytes(rng.randrange(256) for _ in range(301 + 97 * i)))
        with pytest.raises(ModelError) as caught:
            load_mesh(str(path), field='bodies.noise.')
        message = str(caught.value)
        assert message.startswith(f"bodies.noise.mesh_path: '{path}' "), message
        assert '\n' not in message and 'No module named' not in message, message


def test_one_version_in_package_xml_read_by_setup_py_and_rbd_ros(tmp_path):
    import rbd_ros
    version = PACKAGE_XML.findtext('version')
    assert rbd_ros.__version__ == version
    assert _setup_py('--version').strip().splitlines()[-1] == version
    # Change it in package.xml alone: setup.py and rbd_ros (source tree) follow.
    copy = _copy_package(tmp_path / 'rbd_ros')
    xml = copy / 'package.xml'
    xml.write_text(xml.read_text().replace(f'<version>{version}</version>',
                                           '<version>9.8.7</version>'))
    assert _setup_py('--version', cwd=copy).strip().splitlines()[-1] == '9.8.7'
    run = subprocess.run([sys.executable, '-c', 'import rbd_ros; print(rbd_ros.__version__)'],
                         cwd=copy, env=_clean_env(), capture_output=True, text=True, timeout=60)
    assert run.stdout.strip() == '9.8.7', run.stdout + run.stderr


def test_colcon_files_are_right():
    # ament_python: the executables in lib/<package> (where ros2 run looks), and the resource
    # index marker named like the package (empty: its content is not read).
    cfg = (REPO / 'setup.cfg').read_text()
    assert 'script_dir=$base/lib/rbd_ros' in cfg and 'install_scripts=$base/lib/rbd_ros' in cfg
    marker = REPO / 'resource' / PACKAGE_XML.findtext('name')
    assert marker.is_file() and marker.read_text().strip() == ''
    assert PACKAGE_XML.find('export/build_type').text == 'ament_python'
    description = ' '.join(PACKAGE_XML.findtext('description').split())
    for words in ('world of rigid bodies', 'floor', 'obstacles', 'frictional contact', 'MCAP',
                  'bit-exactly', 'robots from URDF', 'joint states'):
        assert words in description, description


@pytest.fixture(scope='module')
def colcon_install(tmp_path_factory):
    """``colcon build`` a copy of the package; return ``(workspace, install prefix)``."""
    tmp_path = tmp_path_factory.mktemp('colcon')
    _copy_package(tmp_path / 'src' / 'rbd_ros')
    colcon = Path(sys.executable).parent / 'colcon'
    build = subprocess.run([str(colcon), 'build', '--base-paths', 'src'], cwd=tmp_path,
                           env=_clean_env(), capture_output=True, text=True, timeout=600)
    assert build.returncode == 0, build.stdout + build.stderr
    return tmp_path, tmp_path / 'install' / 'rbd_ros'


def test_colcon_build_installs_a_runnable_rigid_body_node(colcon_install):
    tmp_path, prefix = colcon_install
    env = _clean_env()
    executable = prefix / 'lib' / 'rbd_ros' / 'rigid_body_node'
    assert executable.is_file() and os.access(executable, os.X_OK)
    for name in ('replay', 'plot'):
        assert (prefix / 'lib' / 'rbd_ros' / name).is_file()
    assert (prefix / 'share' / 'ament_index' / 'resource_index' / 'packages' / 'rbd_ros').is_file()
    assert (prefix / 'share' / 'rbd_ros' / 'package.xml').is_file()
    installed_config = prefix / 'share' / 'rbd_ros' / 'msg_config' / 'default.yaml'
    assert installed_config.is_file()

    site = next(prefix.glob('lib/python3*/site-packages'))
    run_env = dict(env, PYTHONPATH=str(site))
    which = subprocess.run([sys.executable, '-c', 'import rbd_ros; print(rbd_ros.__file__)'],
                           cwd=tmp_path, env=run_env, capture_output=True, text=True, timeout=60)
    assert which.stdout.startswith(str(site)), which.stdout + which.stderr
    run = subprocess.run(
        [str(executable), '--ros-args', '--params-file', str(installed_config),
         '-p', 'duration_s:=0.05', '-p', 'real_time_factor:=0.0'],
        cwd=tmp_path, env=run_env, capture_output=True, text=True, timeout=FIRST_START_S)
    assert run.returncode == 0, run.stdout + run.stderr
    assert 'duration_s reached at t = 50000000 ns' in run.stderr
    # A world with a mesh: installed with its mesh, which its relative mesh_path finds; and a
    # package:// URI found through the ament index (AMENT_PREFIX_PATH, as setup.bash sets it).
    mesh_world = prefix / 'share' / 'rbd_ros' / 'msg_config' / 'l_block_bin.yaml'
    assert (prefix / 'share' / 'rbd_ros' / 'msg_config' / 'meshes' / 'l_block.stl').is_file()
    for extra in ([], ['-p', 'mesh_path:=package://rbd_ros/msg_config/meshes/l_block.stl']):
        run = subprocess.run(
            [str(executable), '--ros-args', '--params-file', str(mesh_world),
             '-p', 'duration_s:=0.05', '-p', 'real_time_factor:=0.0', *extra],
            cwd=tmp_path, env=dict(run_env, AMENT_PREFIX_PATH=str(prefix)),
            capture_output=True, text=True, timeout=FIRST_START_S)
        assert run.returncode == 0, run.stdout + run.stderr
    version = subprocess.run(
        [sys.executable, '-c', 'import importlib.metadata as m, rbd_ros; '
         "print(m.version('rbd_ros'), rbd_ros.__version__)"],
        cwd=tmp_path, env=run_env, capture_output=True, text=True, timeout=60)
    assert version.stdout.split() == [PACKAGE_XML.findtext('version')] * 2, version.stderr


def _launch_tree():
    return ast.parse((REPO / 'launch' / 'rbd_ros.launch.py').read_text())


def _call_name(call):
    return getattr(call.func, 'id', getattr(call.func, 'attr', None))


def test_launch_file_declares_its_arguments_and_points_at_installed_files(colcon_install):
    source = REPO / 'launch' / 'rbd_ros.launch.py'
    compile(source.read_text(), str(source), 'exec')
    calls = [n for n in ast.walk(_launch_tree()) if isinstance(n, ast.Call)]
    declared = [c.args[0].value for c in calls if _call_name(c) == 'DeclareLaunchArgument']
    assert sorted(declared) == sorted(LAUNCH_ARGUMENTS)
    # Each is used: LaunchConfiguration('name'), or _flag(context, 'name') for a boolean.
    used = {c.args[-1].value for c in calls if _call_name(c) in ('LaunchConfiguration', '_flag')
            and isinstance(c.args[-1], ast.Constant)}
    assert used == LAUNCH_ARGUMENTS
    # Files it finds in the package's share directory: os.path.join(share, 'dir', 'file').
    pointed = [Path(*(a.value for a in c.args[1:])) for c in calls
               if _call_name(c) == 'join' and isinstance(c.args[0], ast.Name)
               and c.args[0].id == 'share']
    assert sorted(map(str, pointed)) == ['msg_config/default.yaml', 'rviz/rbd_ros.rviz']
    _, prefix = colcon_install
    share = prefix / 'share' / 'rbd_ros'
    assert (share / 'launch' / 'rbd_ros.launch.py').read_bytes() == source.read_bytes()
    for relative in pointed:
        assert (REPO / relative).is_file() and (share / relative).is_file(), relative
    # Two Node actions: rigid_body_node of this package, and rviz2; both in the namespace, both
    # given parameters (the params file and use_sim_time; RViz its use_sim_time).
    nodes = {k.value.value: {k.arg for k in c.keywords} for c in calls if _call_name(c) == 'Node'
             for k in c.keywords if k.arg == 'executable'}
    assert set(nodes) == {'rigid_body_node', 'rviz2'}
    for keywords in nodes.values():
        assert {'package', 'executable', 'namespace', 'parameters'} <= keywords
    (package,) = [n.value.value for n in _launch_tree().body if isinstance(n, ast.Assign)
                  and n.targets[0].id == 'PACKAGE']
    assert package == PACKAGE_XML.findtext('name')
    # The node's executable is a console script of the package.
    assert "'rigid_body_node = rbd_ros.node:main'" in (REPO / 'setup.py').read_text()


def _rviz():
    return yaml.safe_load((REPO / 'rviz' / 'rbd_ros.rviz').read_text())


RVIZ_TYPES = {'rviz_default_plugins/MarkerArray': 'visualization_msgs/msg/MarkerArray',
              'rviz_default_plugins/PoseArray': 'geometry_msgs/msg/PoseArray'}
RVIZ_DURABILITY = {'Volatile': DurabilityPolicy.VOLATILE,
                   'Transient Local': DurabilityPolicy.TRANSIENT_LOCAL}


def test_rviz_config_shows_what_the_node_publishes(tmp_path):
    config = _rviz()['Visualization Manager']
    assert config['Global Options']['Fixed Frame'] == PARAMETERS_BY_NAME['world_frame'].default
    displays = {d['Class']: d for d in config['Displays']}
    assert 'rviz_default_plugins/TF' in displays
    topics = {d['Topic']['Value']: d for d in config['Displays'] if 'Topic' in d}
    published = set(endpoints.OUTPUT_TOPICS) | {outputs.topic_of('poses')}
    assert set(topics) == {'markers', 'static_markers', outputs.topic_of('poses')}
    assert set(topics) <= published
    tools = [t for t in config['Tools'] if 'Topic' in t]
    assert [t['Topic']['Value'] for t in tools] == ['/' + drag.CLICKED_POINT]
    # What the node really offers on them (a world with contact, in a namespace of its own, as
    # the launch file runs RViz in the node's namespace): type and durability, through DDS.
    ns = f'/rviz_{os.getpid()}'
    # stack.yaml: a world (bodies, so poses) with a floor and obstacles (markers).
    world = REPO / 'msg_config' / 'stack.yaml'
    with open(tmp_path / 'err', 'wb') as err:
        process = subprocess.Popen(
            [sys.executable, '-m', 'rbd_ros.node', '--ros-args', '-r', f'__ns:={ns}',
             '--params-file', str(world)], cwd=tmp_path, stdout=subprocess.DEVNULL, stderr=err)
    context = Context()
    rclpy.init(context=context)
    probe = rclpy.create_node(f'rviz_probe_{os.getpid()}', namespace=ns, context=context)
    try:
        wanted = dict(topics, **{'/tf': displays['rviz_default_plugins/TF']})
        offered = {}
        deadline = time.monotonic() + 120.0  # a warm start takes ~2 s; a cold one far more
        while len(offered) < len(wanted) and time.monotonic() < deadline:
            assert process.poll() is None, (tmp_path / 'err').read_text()
            for topic in wanted:
                infos = probe.get_publishers_info_by_topic(probe.resolve_topic_name(topic))
                if infos:
                    offered[topic] = infos[0]
            time.sleep(0.1)
        assert set(offered) == set(wanted), (tmp_path / 'err').read_text()
        assert offered['/tf'].topic_type == 'tf2_msgs/msg/TFMessage'
        for topic, display in topics.items():
            assert offered[topic].topic_type == RVIZ_TYPES[display['Class']], topic
            assert offered[topic].qos_profile.durability == \
                RVIZ_DURABILITY[display['Topic']['Durability Policy']], topic
    finally:
        probe.destroy_node()
        rclpy.shutdown(context=context)
        process.terminate()
        process.wait(timeout=30)


def _ros_wheels():
    """Return the pinned requirements of the ROS wheels (the ros-jazzy-* of rclpy and msgs)."""
    pins = _pins()
    return [pins[name][0] for name in ('ros-jazzy-rclpy', 'ros-jazzy-common-interfaces')]


def test_pip_install_in_a_clean_venv_imports_checks_and_plots(tmp_path):
    venv = tmp_path / 'venv'
    subprocess.run([sys.executable, '-m', 'venv', str(venv)], check=True, timeout=300)
    python = venv / 'bin' / 'python'
    env = _clean_env()
    # --no-compile: pip byte-compiles every file it installs (the ROS wheels' thousands of
    # message modules), CPU that checks nothing here; what is imported compiles as usual.
    pip = [str(python), '-m', 'pip', 'install', '--quiet', '--disable-pip-version-check',
           '--no-compile']
    for what in (_ros_wheels(), [str(_copy_package(tmp_path / 'src'))]):
        run = subprocess.run(pip + what, cwd=tmp_path, env=env, capture_output=True, text=True,
                             timeout=1800)
        assert run.returncode == 0, run.stdout + run.stderr
    check = subprocess.run([str(python), '-m', 'pip', 'check'], cwd=tmp_path, env=env,
                           capture_output=True, text=True, timeout=300)
    assert check.returncode == 0, check.stdout + check.stderr
    imports = subprocess.run(
        [str(python), '-c', 'import importlib, sys\n'
         'for name in sys.argv[1:]:\n'
         '    module = importlib.import_module(name)\n'
         '    assert module.__file__.startswith(sys.prefix), module.__file__\n'
         'import importlib.metadata as m, rbd_ros\n'
         "print(m.version('rbd_ros'), rbd_ros.__version__)", *_modules()],
        cwd=tmp_path, env=env, capture_output=True, text=True, timeout=FIRST_START_S)
    assert imports.returncode == 0, imports.stdout + imports.stderr
    assert imports.stdout.split() == [PACKAGE_XML.findtext('version')] * 2
    out = tmp_path / 'l_block_bin.png'
    plot = subprocess.run([str(venv / 'bin' / 'plot'), str(REPO / 'bags' / 'l_block_bin'),
                           '-o', str(out)], cwd=tmp_path, env=env, capture_output=True,
                          text=True, timeout=FIRST_START_S)
    assert plot.returncode == 0, plot.stdout + plot.stderr
    assert out.stat().st_size > 10_000  # a figure of curves, not an empty file
    assert (venv / 'share' / 'rbd_ros' / 'launch' / 'rbd_ros.launch.py').is_file()
