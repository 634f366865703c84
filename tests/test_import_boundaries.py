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
The layers are the folders of ``rbd_ros/``, and imports point one way; read from the files.

``core`` (physics) ← ``sim`` (the ROS-free application) ← ``msgs`` (ROS messages) ← ``bag``
(recordings and the tools on them) ← ``ros`` (the node). A module may import its own layer and
the layers before it, never one after it; each layer's ``__init__`` says so in one line.
Besides the static walk, fresh interpreters show what importing a layer loads: no rclpy below
``ros``, and no message package below ``msgs``.
"""

import ast
from pathlib import Path
import subprocess
import sys

import pytest

REPO = Path(__file__).resolve().parents[1]
PACKAGE = REPO / 'rbd_ros'
LAYERS = ('core', 'sim', 'msgs', 'bag', 'ros')
# Outside the layers: the package's own __init__ (its version), the two commands users type
# (``python -m rbd_ros.node``, ``python -m rbd_ros.demo``), and the paths of this release that
# moved into the layers (CHANGELOG.rst); each imports only what it names.
TOP_LEVEL = {'__init__', 'node', 'demo', 'recording', 'replay', 'session', 'plot'}
RCLPY = ('rclpy',)
MESSAGE_PACKAGES = ('geometry_msgs', 'nav_msgs', 'diagnostic_msgs', 'rosgraph_msgs',
                    'tf2_msgs', 'builtin_interfaces', 'std_msgs', 'visualization_msgs',
                    'sensor_msgs', 'trajectory_msgs')


def module_name(path):
    parts = path.relative_to(REPO).with_suffix('').parts
    return '.'.join(parts[:-1] if parts[-1] == '__init__' else parts)


def layer_modules(layer):
    return sorted(module_name(p) for p in (PACKAGE / layer).rglob('*.py'))


def rbd_imports(path):
    """Every ``rbd_ros`` module a file imports, at the top or inside a function."""
    found = set()
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            found |= {a.name for a in node.names if a.name.split('.')[0] == 'rbd_ros'}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            if node.module.split('.')[0] == 'rbd_ros':
                found.add(node.module)
                # ``from rbd_ros.sim import config``: the names may be modules
                found |= {f'{node.module}.{a.name}' for a in node.names
                          if (PACKAGE.parent / f'{node.module}.{a.name}'.replace('.', '/')
                              ).with_suffix('.py').exists()}
    return found


def layer_of(module):
    parts = module.split('.')
    return parts[1] if len(parts) > 1 and parts[1] in LAYERS else None


def test_every_module_is_in_a_layer_folder():
    folders = sorted(p.name for p in PACKAGE.iterdir()
                     if p.is_dir() and p.name != '__pycache__')
    assert folders == sorted(LAYERS)
    top = {p.stem for p in PACKAGE.glob('*.py')}
    assert top == TOP_LEVEL, f'modules outside the layers: {sorted(top - TOP_LEVEL)}'


@pytest.mark.parametrize('layer', LAYERS)
def test_each_layer_says_what_it_may_import(layer):
    doc = ast.get_docstring(ast.parse((PACKAGE / layer / '__init__.py').read_text()))
    assert doc, f'rbd_ros/{layer}/__init__.py has no docstring'
    assert 'import' in doc.splitlines()[0].lower(), doc


@pytest.mark.parametrize('layer', LAYERS)
def test_imports_point_one_way(layer):
    allowed = LAYERS[:LAYERS.index(layer) + 1]
    wrong = {}
    for path in sorted((PACKAGE / layer).rglob('*.py')):
        bad = sorted(m for m in rbd_imports(path)
                     if m != 'rbd_ros' and layer_of(m) not in allowed)  # the root: __version__
        if bad:
            wrong[str(path.relative_to(REPO))] = bad
    assert not wrong, f'{layer} may import only {allowed}: {wrong}'


def test_the_top_level_modules_import_only_what_they_name():
    for stem in TOP_LEVEL - {'__init__'}:
        targets = rbd_imports(PACKAGE / f'{stem}.py')
        assert targets and all(layer_of(m) for m in targets), (stem, targets)
    assert rbd_imports(PACKAGE / '__init__.py') == set()


def test_the_walk_sees_a_wrong_import(tmp_path):
    """The static walk would catch ``core`` importing ``sim`` inside a function."""
    probe = tmp_path / 'probe.py'
    probe.write_text('def f():\n    from rbd_ros.sim import config\n    import rbd_ros.ros.node\n')
    assert rbd_imports(probe) == {'rbd_ros.sim', 'rbd_ros.sim.config', 'rbd_ros.ros.node'}
    assert {layer_of(m) for m in rbd_imports(probe)} == {'sim', 'ros'}


def imported(modules, packages):
    """Import ``modules`` in a fresh interpreter; return which of ``packages`` got loaded."""
    code = (
        'import importlib, sys\n'
        f'for name in {modules!r}:\n'
        '    importlib.import_module(name)\n'
        f'print(sorted({{m.split(".")[0] for m in sys.modules}} & set({packages!r})))\n'
    )
    proc = subprocess.run([sys.executable, '-c', code], capture_output=True, text=True,
                          cwd=REPO, timeout=120)
    assert proc.returncode == 0, proc.stderr
    return proc.stdout.strip()


@pytest.mark.parametrize('layer', ('core', 'sim'))
def test_no_rclpy_and_no_messages_below_the_message_layer(layer):
    found = imported(tuple(layer_modules(layer)), RCLPY + MESSAGE_PACKAGES)
    assert found == '[]', f'{layer} imported {found}'


@pytest.mark.parametrize('layer', ('msgs', 'bag'))
def test_no_rclpy_in_the_message_layer_and_the_bag_tools(layer):
    found = imported(tuple(layer_modules(layer)), RCLPY)
    assert found == '[]', f'{layer} imported {found}'


def test_recording_and_animation_need_no_message_package():
    """A bag is written and drawn from plain values and CDR bytes."""
    found = imported(('rbd_ros.bag.recording', 'rbd_ros.bag.animate'), MESSAGE_PACKAGES)
    assert found == '[]', found
