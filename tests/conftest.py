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
Shared test set-up: an isolated DDS domain per test process and helpers to drive the node.

Every pytest process gets its own ``ROS_DOMAIN_ID`` (derived from its pid, in 1..101) and
``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, set here before anything initialises rclpy, and
inherited by the node subprocesses. Under pytest-xdist (``.ci/run`` runs ``-n 2``) worker ``gwK``
takes the run's domain plus K (mod 101), so two workers of one run never share a domain.
Nothing waits with a fixed sleep for discovery: the helpers poll with a deadline
(:func:`wait_until`).
"""

import itertools
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

import node_forks
import pytest
import yaml

REPO = pathlib.Path(__file__).resolve().parents[1]
#: How long a node's first start may take: compiling the contact step takes about 3 min on
#: this machine, more under load (the demo waits as long).
FIRST_START_S = 900.0
if str(REPO) not in sys.path:  # the package is tested from its source tree
    sys.path.insert(0, str(REPO))


def domain_id_for(pid):
    """Return a ROS domain id in 1..101 for process ``pid`` (0 is everyone's default)."""
    return 1 + pid % 101


def worker_index():
    """Return this pytest-xdist worker's index (``gw3`` → 3), or None outside a worker."""
    worker = os.environ.get('PYTEST_XDIST_WORKER', '')
    return int(worker[2:]) if worker.startswith('gw') else None


def run_domain_id():
    """
    Return this process's ROS domain id, and export the run's for the xdist workers it starts.

    RBD_TEST_DOMAIN_ID pins the run's domain (several test runs side by side on one machine);
    else a plain run or xdist's controller takes :func:`domain_id_for` its pid and exports it as
    RBD_TEST_RUN_DOMAIN_ID, which its workers inherit: worker K uses that plus K (wrapped past
    101 back to 1 when the run's domain is in 1..101), so the workers of one run (at most 101)
    never collide, and a pinned run with N workers uses N consecutive domains.
    """
    index = worker_index()
    if index is None:
        base = int(os.environ.get('RBD_TEST_DOMAIN_ID') or domain_id_for(os.getpid()))
        os.environ['RBD_TEST_RUN_DOMAIN_ID'] = str(base)
        return base
    base = int(os.environ.get('RBD_TEST_RUN_DOMAIN_ID') or os.environ.get('RBD_TEST_DOMAIN_ID')
               or domain_id_for(os.getppid()))
    domain = base + index
    return domain - 101 if base <= 101 < domain else domain


os.environ['ROS_DOMAIN_ID'] = str(run_domain_id())
os.environ['ROS_AUTOMATIC_DISCOVERY_RANGE'] = 'LOCALHOST'
os.environ.pop('ROS_LOCALHOST_ONLY', None)
os.environ['PYTHONPATH'] = os.pathsep.join(
    [str(REPO)] + [p for p in os.environ.get('PYTHONPATH', '').split(os.pathsep) if p])
os.environ.setdefault('PYTHONUNBUFFERED', '1')


def wait_until(predicate, timeout_s, spin=None, what='condition'):
    """
    Poll ``predicate`` until it returns a truthy value or ``timeout_s`` passes; return the value.

    :param spin: called between polls (e.g. spin an executor once with a short timeout); if
        None, the poll sleeps 10 ms.
    :raises AssertionError: on timeout, naming ``what``.
    """
    deadline = time.monotonic() + timeout_s
    while True:
        value = predicate()
        if value:
            return value
        if time.monotonic() > deadline:
            raise AssertionError(f'timed out after {timeout_s} s waiting for {what}')
        if spin is None:
            time.sleep(0.01)
        else:
            spin()


def write_params(path, params):
    """Write ``params`` as a ROS 2 parameter file for any node name (``/**``)."""
    path = pathlib.Path(path)
    path.write_text(yaml.safe_dump({'/**': {'ros__parameters': params}}))
    return path


_NAMESPACES = itertools.count()


class NodeProcess:
    """
    A ``rigid_body_node`` subprocess started the way a user starts it.

    With ``namespace=True`` it gets a namespace of its own (:attr:`namespace`), so endpoints that
    DDS still remembers from an earlier node of the same test process can never be mistaken for
    this one's; a string is used as the namespace; None (default) keeps the root namespace.
    """

    def __init__(self, tmp_path, params=None, params_file=None, extra_args=(), command=None,
                 namespace=None):
        args = ['--ros-args']
        if namespace is True:
            namespace = f'/rbd_test_{os.getpid()}_{next(_NAMESPACES)}'
        if namespace:
            args += ['-r', f'__ns:={namespace}']
        self.namespace = namespace or '/'
        if params_file is not None:
            args += ['--params-file', str(params_file)]
        if params:
            args += ['--params-file', str(write_params(
                pathlib.Path(tmp_path) / f'params_{id(self)}.yaml', params))]
        args += list(extra_args)
        self.stdout_path = pathlib.Path(tmp_path) / f'node_{id(self)}.out'
        self.stderr_path = pathlib.Path(tmp_path) / f'node_{id(self)}.err'
        with open(self.stdout_path, 'wb') as out, open(self.stderr_path, 'wb') as err:
            # Forked from a server with numpy and numba imported (tests/node_forks.py): the
            # same `python -m rbd_ros.node`, ~0.35 CPU-s less a start; else a fresh process.
            self.process = None if command else node_forks.fork_node(
                args, tmp_path, self.stdout_path, self.stderr_path)
            if self.process is None:
                self.process = subprocess.Popen(
                    (command or [sys.executable, '-m', 'rbd_ros.node']) + args, stdout=out,
                    stderr=err, cwd=str(tmp_path))

    @property
    def stderr(self):
        """Everything the node wrote to stderr so far (rclpy logs go there)."""
        return self.stderr_path.read_text(errors='replace')

    def wait(self, timeout_s):
        """Wait for the process to exit; return its status."""
        return self.process.wait(timeout=timeout_s)

    def stop(self, sig=signal.SIGINT, timeout_s=15.0):
        """Send ``sig`` and wait for the exit status (kill after ``timeout_s``)."""
        if self.process.poll() is None:
            self.process.send_signal(sig)
            try:
                return self.process.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
                raise
        return self.process.returncode


@pytest.fixture
def start_node(tmp_path):
    """Return ``start(params, params_file, extra_args, namespace)`` → a :class:`NodeProcess`."""
    started = []

    def start(params=None, params_file=None, extra_args=(), namespace=None):
        node = NodeProcess(tmp_path, params, params_file, extra_args, namespace=namespace)
        started.append(node)
        return node

    yield start
    for node in started:
        node.stop()


@pytest.fixture
def probe_for():
    """Return ``make(node, **options)``: a :class:`ros_probe.Probe` on the node, closed after."""
    from ros_probe import Probe  # rclpy: only for the tests that talk to a node
    made = []

    def make(node, **options):
        probe = Probe(node.namespace, **options)
        made.append(probe)
        return probe
    yield make
    for probe in made:
        probe.close()


@pytest.fixture(scope='module')
def module_tmp(tmp_path_factory):
    """Return a temporary directory shared by one test module (for module-scoped nodes)."""
    return tmp_path_factory.mktemp('module')


# --- The kernels compile once, in the background, while tests that need none run -----------
#
# A fresh clone's first contact test compiles the contact step for ~1.5 min of one core, a joints
# test the joints step for ~1.5 min, a world with joints its own specialisation of the contact
# step and the batch test the threaded kernel for ~1 min, while the other core idles. So the
# session starts `python -m rbd_ros.core.warmup --batch` in a background process (it fills the
# same per-user cache the tests and their nodes read; free, contact, joints, world_joints, then
# batch) and runs the tests in tiers: first those that compile nothing, then those that need only
# the free-body step (compiled first, ~15 s), then, once the free and contact kinds are marked on
# disk (jitcache.kernels_on_disk), those that need no more (the contact step: ~1.5 min before
# the joints step is ready, which both workers spent waiting), then, with the joints kind, the
# rest but the jointed worlds' and the batch tests; the jointed worlds' once their kind is
# marked too, and the batch tests last, once the warm-up has ended. A test that waited for its
# kinds never compiles them again beside the warm-up. Nothing is skipped: a warm-up that fails
# only means the tests compile the kernels themselves, as they would without it. With a warm
# cache the process ends in ~2 s.

#: Test files that compile no physics kernel (run first, beside the warm-up).
NO_KERNEL_FILES = ('test_lint.py', 'test_docs.py', 'test_import_boundaries.py', 'test_warm_up.py',
                   'core/test_rotations.py', 'core/test_inertia.py', 'core/test_layout.py',
                   'core/test_validators.py')
#: Single tests (file::name) that compile no physics kernel: the clean-venv install (~1 min of
#: pip), the package metadata checks, the colcon-installed launch file, the RViz config and the
#: mesh loader's one-line error (each run with an empty kernel cache: nothing compiled). Under
#: pytest-xdist a file runs on one worker in one go, so a file's tests of a later tier make
#: that worker wait for the warm-up there: test_package.py's only test that needs a kernel is the
#: installed node's start (the contact step).
NO_KERNEL_TESTS = tuple(
    f'test_package.py::{name}' for name in (
        'test_pip_install_in_a_clean_venv_imports_checks_and_plots',
        'test_every_third_party_import_is_declared_for_pip_and_rosdep',
        'test_install_requires_lower_bounds_are_the_tested_pins',
        'test_one_version_in_package_xml_read_by_setup_py_and_rbd_ros',
        'test_colcon_files_are_right',
        'test_launch_file_declares_its_arguments_and_points_at_installed_files',
        'test_rviz_config_shows_what_the_node_publishes',
        'test_random_bytes_stl_is_a_one_line_error_naming_mesh_path'))
#: Test files that need the free-body step only (run once the warm-up compiled it): the core's
#: tests outside contact/, joints/ and the batch kernel, and these (no contact, no timing that a
#: compile on the other core would disturb). Not ros/test_sim_session.py: its drag tests run
#: msg_config/stack.yaml, a contact world (in this tier it compiled the contact step beside the
#: warm-up's own compile of it: 111 s of a cold run). Nor recording/test_replay.py: it replays
#: two robots (the joints step, compiled in-process beside the warm-up's own compile of it).
FREE_KERNEL_DIR = 'core/'
FREE_KERNEL_FILES = ('ros/test_node_physics.py',
                     'ros/test_node_inputs.py', 'ros/test_node_outputs.py',
                     'ros/test_node_across_hosts.py',
                     'recording/test_recording.py', 'recording/test_public_api.py',
                     'recording/test_replay_integrity.py', 'recording/test_bag_limits.py')
#: Below FREE_KERNEL_DIR, what needs more than the free-body step.
NOT_FREE_DIRS = ('core/contact/', 'core/joints/')
#: Test files that need the contact step (worlds without joints, no robot) and at most the
#: free-body step besides: everything below CONTACT_KERNEL_DIR (but the files of a later tier
#: listed below), and these, which run worlds and free bodies only (nodes, recordings, replays
#: and plots of them, bags of worlds). Each was read for joints, robots, URDF and the msg_config/
#: files with joints, and run with a kernel cache holding only the free and contact kinds:
#: nothing compiled the joints step. A file listed here by mistake compiles the joints step
#: beside the warm-up's own compile of it (~100 s of CPU).
CONTACT_KERNEL_DIR = 'core/contact/'
CONTACT_KERNEL_FILES = ('recording/test_animate.py', 'recording/test_hostile_bags.py',
                        'recording/test_node_recording.py',
                        'recording/test_node_recording_faults.py',
                        'recording/test_run_endings.py', 'recording/test_world_sigkill.py',
                        'ros/test_demo.py', 'ros/test_marker_bytes.py', 'ros/test_node_behind.py',
                        'ros/test_node_big_world.py', 'ros/test_node_cli.py',
                        'ros/test_node_contact.py', 'ros/test_node_drag_limits.py',
                        'ros/test_node_flood.py', 'ros/test_node_overrides.py',
                        'ros/test_node_signals.py', 'ros/test_node_small_things.py',
                        'ros/test_node_threads.py', 'ros/test_node_world.py',
                        'ros/test_node_world_hard_push.py', 'ros/test_participant.py',
                        'ros/test_readme_tour.py', 'ros/test_sim_session.py', 'ros/test_tf.py',
                        'sim/test_hostile_meshes.py', 'test_package.py')
#: Test files that step worlds with joints (their own specialisation of the contact step:
#: a world's joints, or URDF robots among bodies), replay bags of them, or start a node on every
#: file of msg_config/ (``pendulum_world.yaml``, ``door_world.yaml`` and ``arm_table.yaml``
#: have joints). A file missing here compiles that specialisation beside the warm-up's own
#: compile of it (~90 s of CPU more, per process that does): cone limits in contact, the
#: threaded world's jointed case, robots on the ground.
WORLD_JOINTS_FILES = ('core/joints/test_joints_contact.py', 'core/joints/test_motors_contact.py',
                      'core/joints/test_joint_friction_contact.py',
                      'core/joints/test_coordinate_motors_contact.py',
                      'sim/test_coordinate_joints.py', 'ros/test_node_coordinate_joints.py',
                      'core/joints/test_cone_limit_contact.py', 'core/contact/test_parallel.py',
                      'sim/test_world_joints.py', 'sim/test_robot_contact.py',
                      'sim/test_pacing_diagnostics.py', 'ros/test_node_robot_outputs.py',
                      'ros/test_node_world_joints.py', 'ros/test_node_world_joints_robots.py',
                      'ros/test_node_robot_contact.py',
                      'ros/test_node_world_start_refusals.py', 'ros/test_node_lifecycle.py',
                      'ros/test_param_dump.py', 'ros/test_node_analytic_unseen.py',
                      'recording/test_reference_bags.py')
#: The test files of the threaded batch kernel: the last tier (the warm-up compiles it last).
BATCH_KERNEL_FILES = ('core/test_batch.py',)
#: The kernel kinds (jitcache.KIND_MODULES) each tier waits for; the last tier waits for the
#: warm-up's end.
TIER_KINDS = {1: ('free',), 2: ('free', 'contact'), 3: ('free', 'contact', 'joints'),
              4: ('free', 'contact', 'joints', 'world_joints')}
#: The tier of a test that needs every kind but the jointed worlds' and the batch kernel.
JOINTS_TIER = 3
_WARM_UP = {}


def _tier_of(path, name):
    """Return the tier (0 to 5) of test ``name`` in ``path`` (relative to tests/, posix)."""
    if path in NO_KERNEL_FILES or f'{path}::{name}' in NO_KERNEL_TESTS:
        return 0
    if path in BATCH_KERNEL_FILES:
        return 5
    if path in WORLD_JOINTS_FILES:
        return 4
    if path in FREE_KERNEL_FILES or path.startswith(FREE_KERNEL_DIR) and not path.startswith(
            NOT_FREE_DIRS):
        return 1
    if path in CONTACT_KERNEL_FILES or path.startswith(CONTACT_KERNEL_DIR):
        return 2
    return JOINTS_TIER


def _tier(item):
    return _tier_of(item.path.relative_to(REPO / 'tests').as_posix(), item.name)


class AdoptedWarmUp:
    """
    The warm-up ``.ci/setup`` started beside pip (``RBD_TEST_ADOPT_WARM_UP``), followed as a child.

    It is not this process's child: it is alive while ``/proc/<pid>`` shows it running (not a
    zombie, which no one may reap), its output is read from its log as it grows, and its exit
    status from the status file it writes at its end (none: killed).  The few methods of
    :class:`subprocess.Popen` the warm-up code calls.
    """

    def __init__(self, stem):
        self.pid = int(pathlib.Path(stem + '.pid').read_text())
        self.log, self.status = pathlib.Path(stem + '.log'), pathlib.Path(stem + '.status')
        self.returncode = None
        self.stdout = self._lines()

    @classmethod
    def adopt(cls):
        """Return the running warm-up the environment names, else None."""
        stem = os.environ.get('RBD_TEST_ADOPT_WARM_UP')
        try:
            adopted = cls(stem) if stem else None
        except (OSError, ValueError):
            return None
        if adopted is None or not adopted._alive() and not adopted.status.exists():
            return None
        return adopted

    def _alive(self):
        try:
            cmdline = pathlib.Path(f'/proc/{self.pid}/cmdline').read_bytes()
            state = pathlib.Path(f'/proc/{self.pid}/stat').read_text().rsplit(')', 1)[1].split()
        except (OSError, IndexError):
            return False
        return b'rbd_ros.core.warmup' in cmdline and state[0] != 'Z'

    def _lines(self):
        with open(self.log) as log:
            while True:
                line = log.readline()
                if line:
                    yield line
                elif self.poll() is not None:
                    yield from log  # what it wrote before it ended
                    return
                else:
                    time.sleep(0.2)

    def poll(self):
        if self.returncode is None and not self._alive():
            try:
                self.returncode = int(self.status.read_text())
            except (OSError, ValueError):
                self.returncode = -signal.SIGKILL
        return self.returncode

    def kill(self):
        if self._alive():
            os.kill(self.pid, signal.SIGKILL)

    def wait(self):
        while self.poll() is None:
            time.sleep(0.2)
        return self.returncode

    def communicate(self):
        self.wait()
        return ''.join(self.stdout), None


def _start_warm_up():
    _WARM_UP['process'] = AdoptedWarmUp.adopt() or subprocess.Popen(
        [sys.executable, '-u', '-m', 'rbd_ros.core.warmup', '--batch'], cwd=REPO,
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    _WARM_UP['started'] = time.monotonic()


def finish_warm_up(process):
    """
    Wait for the warm-up; return ``(exit status, output)``.

    It is killed once FIRST_START_S pass without a line from it (it writes one as each kind is
    ready), not FIRST_START_S after its start: on a loaded machine (load 7-9, one core to a few
    processes) a whole warm-up took longer, was killed while compiling the contact step with
    joints, and every test of the later tiers then compiled that kind and the batch kernel
    itself, several processes at a time.
    """
    lines = []

    def read():
        for line in process.stdout:
            lines.append(line)
    reader = threading.Thread(target=read, name='warm-up output', daemon=True)
    reader.start()
    seen, deadline = 0, time.monotonic() + FIRST_START_S
    while process.poll() is None:
        if len(lines) > seen:
            seen, deadline = len(lines), time.monotonic() + FIRST_START_S
        elif time.monotonic() > deadline:
            process.kill()
            break
        time.sleep(0.2)
    process.wait()
    reader.join()
    return process.returncode, ''.join(lines)


def _report_warm_up(status, out):
    if status != 0:
        print(f'\nkernel warm-up failed (exit {status}); the tests compile the kernels '
              f'themselves:\n{out}')


def pytest_collection_modifyitems(session, config, items):
    """Order the tests by tier (stable within one) and start the background warm-up."""
    items.sort(key=_tier)
    if worker_index() is not None:  # an xdist worker: the controller runs the run's warm-up
        return
    if os.environ.get('RBD_TEST_NO_WARM_UP') or not any(_tier(i) for i in items):
        return
    _start_warm_up()


# --- Under pytest-xdist: one warm-up for the run, started by the controller ----------------
#
# Each worker collects and sorts the same tests (so xdist hands them out in tier order), but
# only the controller starts the warm-up, once a worker's collection holds a test that needs a
# kernel and before any test is handed out: it makes the directory _shared_dir() names (the
# workers know the run's id), and a thread of its own writes ``ended`` there (exit status, then
# the output) when the warm-up ends. A worker with no such directory waits for nothing.


def _shared_dir(testrunuid):
    """Return the directory where xdist's controller tells its workers about the warm-up."""
    return pathlib.Path(tempfile.gettempdir()) / f'rbd_warm_up_{testrunuid}'


def _nodeid_tier(root, nodeid):
    path, _, rest = nodeid.partition('::')
    try:
        path = (root / path).relative_to(REPO / 'tests').as_posix()
    except ValueError:  # not below tests/: treat as needing every kernel
        return JOINTS_TIER
    return _tier_of(path, rest.rsplit('::', 1)[-1])


def _warm_up_for_workers(process, shared):
    status, out = finish_warm_up(process)
    (shared / 'ended.part').write_text(f'{status}\n{out}')
    (shared / 'ended.part').replace(shared / 'ended')


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_node_collection_finished(node, ids):
    """Start the warm-up (xdist's controller) when a worker has collected a test needing one."""
    if 'process' in _WARM_UP or os.environ.get('RBD_TEST_NO_WARM_UP'):
        return
    root = pathlib.Path(node.config.rootpath)
    if not any(_nodeid_tier(root, nodeid) for nodeid in ids):
        return
    shared = _shared_dir(node.workerinput['testrunuid'])
    shared.mkdir(mode=0o700)
    _WARM_UP['shared'] = shared
    _start_warm_up()
    _WARM_UP['thread'] = threading.Thread(
        target=_warm_up_for_workers, args=(_WARM_UP['process'], shared), daemon=True)
    _WARM_UP['thread'].start()


def _wait_for_kinds(tier, ended):
    """Wait until the warm-up has ``ended()`` or marked every kind of ``tier`` on disk."""
    from rbd_ros.core import jitcache
    jitcache.configured()
    kinds = TIER_KINDS[tier]
    wait_until(lambda: ended() or all(jitcache.kernels_on_disk(k) for k in kinds),
               FIRST_START_S, what=f'the {", ".join(kinds)} kernels of the warm-up')


def _wait_for_shared_warm_up(tier):
    if 'ended' in _WARM_UP:
        return
    shared = _shared_dir(os.environ['PYTEST_XDIST_TESTRUNUID'])
    ended = shared / 'ended'
    if not shared.is_dir():  # no warm-up in this run
        _WARM_UP['ended'] = time.monotonic()
        return
    if tier in TIER_KINDS and not ended.exists():
        _wait_for_kinds(tier, ended.exists)
        return
    # The controller ends the warm-up after FIRST_START_S and then writes `ended`.
    wait_until(ended.exists, FIRST_START_S + 60.0, what='the end of the warm-up')
    _WARM_UP['ended'] = time.monotonic()
    status, out = ended.read_text().split('\n', 1)
    _report_warm_up(int(status), out)


def _wait_for_warm_up(tier):
    if worker_index() is not None:
        _wait_for_shared_warm_up(tier)
        return
    process = _WARM_UP.get('process')
    if process is None or 'ended' in _WARM_UP:
        return
    if tier in TIER_KINDS:
        _wait_for_kinds(tier, lambda: process.poll() is not None)
        return
    status, out = finish_warm_up(process)
    _WARM_UP['ended'] = time.monotonic()
    _report_warm_up(status, out)


@pytest.fixture(autouse=True)
def _kernels_warmed_up(request):
    """Before a test that needs compiled kernels, wait for the warm-up to have compiled them."""
    tier = _tier(request.node)
    if tier:
        _wait_for_warm_up(tier)


def pytest_sessionfinish(session, exitstatus):
    """Never leave the warm-up running after the session (nor xdist's shared directory)."""
    process = _WARM_UP.get('process')
    if process is None and worker_index() is None:
        process = AdoptedWarmUp.adopt()  # set-up's, not needed by the tests run: ended too
    if process is not None and process.poll() is None:
        process.kill()
        if 'thread' not in _WARM_UP:
            process.communicate()
    if 'thread' in _WARM_UP:
        _WARM_UP['thread'].join()
        shutil.rmtree(_WARM_UP['shared'], ignore_errors=True)
