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
Node processes forked from a server that has numpy, numba and rbd_ros's core imported.

The suite starts ~270 nodes, and each ``python -m rbd_ros.node`` spent ~0.35 CPU-s importing
numpy and numba before it did anything of its own (a whole start: ~0.9 CPU-s). This server
(one per test process, started on first use) imports them once; each node is a fork of it
that then runs ``rbd_ros.node`` as ``python -m`` would: ``__main__``, ``sys.argv``, its working
directory first on ``sys.path``, its stdout and stderr files, the test process's environment,
Python's default signal handlers. The server also imports rbd_ros's core and parameter modules
(~0.2 CPU-s more a start, see :func:`_preload`); everything else (rclpy, the messages, the rest
of rbd_ros) is imported after the fork, as in a fresh process: rclpy's extension starts
threads when it loads, and a fork keeps only the thread that forks, so it must not be loaded
before.

:class:`conftest.NodeProcess` forks only when its environment is the one the server started
with (a test that changed ``PYTHONPATH``, ``XDG_CACHE_HOME`` or anything else execs a fresh
``python -m rbd_ros.node``, as do nodes given a command), and ``RBD_TEST_NODE_FORKS=0`` turns
it off. The server reaps its children and writes each exit status to a file that
:class:`ForkedProcess` (what the tests call of :class:`subprocess.Popen`) reads.

Run as a script, this module is the server: one JSON request a line on stdin, the child's pid
a line on stdout.
"""

import atexit
import json
import os
import pathlib
import select
import signal
import subprocess
import sys
import threading
import time


class ForkedProcess:
    """The parts of :class:`subprocess.Popen` the tests use, for a forked node."""

    def __init__(self, pid, status_path, args):
        self.pid, self.args, self.returncode = pid, args, None
        self._status_path = pathlib.Path(status_path)

    def poll(self):
        """Return the exit status (a negative signal number), or None while it runs."""
        if self.returncode is None:
            try:
                self.returncode = int(self._status_path.read_text())
            except (OSError, ValueError):
                return None
        return self.returncode

    def wait(self, timeout=None):
        """Wait for the exit status; raise :class:`subprocess.TimeoutExpired` after ``timeout``."""
        deadline = None if timeout is None else time.monotonic() + timeout
        while self.poll() is None:
            if deadline is not None and time.monotonic() > deadline:
                raise subprocess.TimeoutExpired(self.args, timeout)
            time.sleep(0.005)
        return self.returncode

    def send_signal(self, sig):
        """Send ``sig`` unless the process has been reaped (its pid may be someone else's)."""
        if self.poll() is None:
            try:
                os.kill(self.pid, sig)
            except ProcessLookupError:
                pass

    def terminate(self):
        """Send SIGTERM."""
        self.send_signal(signal.SIGTERM)

    def kill(self):
        """Send SIGKILL."""
        self.send_signal(signal.SIGKILL)


class _Server:
    """This test process's fork server, started on first use, ended when its stdin closes."""

    def __init__(self):
        self.env = dict(os.environ)
        self.process = subprocess.Popen(
            [sys.executable, '-u', __file__], stdin=subprocess.PIPE, stdout=subprocess.PIPE,
            env=self.env)
        self.lock = threading.Lock()
        atexit.register(self.close)

    def close(self):
        """End the server (it reaps its children first) and wait for it."""
        if self.process.poll() is None:
            self.process.stdin.close()
            try:
                self.process.wait(15.0)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()

    def start(self, args, cwd, stdout_path, stderr_path):
        request = {'args': list(args), 'cwd': str(cwd), 'stdout': str(stdout_path),
                   'stderr': str(stderr_path), 'status': f'{stdout_path}.status',
                   'env': dict(os.environ)}
        with self.lock:
            self.process.stdin.write(json.dumps(request).encode() + b'\n')
            self.process.stdin.flush()
            line = self.process.stdout.readline()
        if not line:
            raise RuntimeError('the node fork server ended')
        return ForkedProcess(int(line), request['status'],
                             [sys.executable, '-m', 'rbd_ros.node', *args])


_SERVER = {}
#: Set by pytest for each test phase: handed to the node, not compared.
PER_TEST = ('PYTEST_CURRENT_TEST',)


def _compared(env):
    return {k: v for k, v in env.items() if k not in PER_TEST}


def fork_node(args, cwd, stdout_path, stderr_path):
    """
    Return a :class:`ForkedProcess` running ``python -m rbd_ros.node *args``, or None.

    None (the caller execs): forks turned off, or this process's environment is no longer the
    one the server started with.
    """
    if os.environ.get('RBD_TEST_NODE_FORKS', '1') == '0':
        return None
    server = _SERVER.get(os.getpid())
    if server is None or server.process.poll() is not None:
        server = _SERVER[os.getpid()] = _Server()
    if _compared(os.environ) != _compared(server.env):
        return None
    return server.start(args, cwd, stdout_path, stderr_path)


# --- The server -----------------------------------------------------------------------------


def _preload():
    """
    Import what every node imports first and what is safe to fork.

    numpy, numba, PyYAML and rbd_ros's core and parameter modules (none starts a thread or
    reads the environment when imported: ``rbd_ros.core.jitcache`` chooses its cache when a
    simulator is built): ~0.55 CPU-s of a start, of which rbd_ros's ~0.2.
    """
    # As rbd_ros.node imports numba: without coverage.py (its _import_numba_without_coverage,
    # written again here: importing rbd_ros.node before runpy runs it as __main__ makes runpy
    # warn on the node's stderr, which the tests read)
    if 'coverage' not in sys.modules:
        sys.modules['coverage'] = None
        try:
            import numba  # noqa: F401 - the import is the point
        finally:
            if sys.modules.get('coverage', 0) is None:
                del sys.modules['coverage']
    import numpy  # noqa: F401
    import yaml  # noqa: F401
    import rbd_ros.core  # noqa: F401
    import rbd_ros.sim.config  # noqa: F401


def _serve():
    """Fork a child per request; return the request in the child, None when stdin closes."""
    children = {}  # pid: status path
    stdin = sys.stdin.buffer
    while True:
        while children:
            try:
                pid, status = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                break
            if pid == 0:
                break
            path = children.pop(pid)
            part = pathlib.Path(path + '.part')
            part.write_text(str(os.waitstatus_to_exitcode(status)))
            part.replace(path)
        ready, _, _ = select.select([stdin], [], [], 0.005 if children else 1.0)
        if not ready:
            continue
        line = stdin.readline()
        if not line:  # the test process ends: reap what is left (its CPU time counts then)
            deadline = time.monotonic() + 10.0
            while children and time.monotonic() < deadline:
                pid, _ = os.waitpid(-1, os.WNOHANG)
                children.pop(pid, None) if pid else time.sleep(0.01)
            return None
        request = json.loads(line)
        sys.stdout.flush()
        sys.stderr.flush()
        pid = os.fork()
        if pid == 0:
            return request
        children[pid] = request['status']
        sys.stdout.write(f'{pid}\n')
        sys.stdout.flush()


def _run_node(request):
    """In the child: become ``python -m rbd_ros.node <args>`` (this function does not return)."""
    import runpy
    for signum in (signal.SIGINT, signal.SIGTERM, signal.SIGCHLD):
        signal.signal(signum, signal.default_int_handler if signum == signal.SIGINT
                      else signal.SIG_DFL)
    null = os.open(os.devnull, os.O_RDONLY)
    os.dup2(null, 0)
    os.close(null)
    for fd, path in ((1, request['stdout']), (2, request['stderr'])):
        out = os.open(path, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        os.dup2(out, fd)
        os.close(out)
    os.chdir(request['cwd'])
    os.environ.clear()
    os.environ.update(request['env'])
    sys.path[0] = os.getcwd()  # python -m: the working directory first
    sys.argv = ['-m', *request['args']]  # run_module puts the module's path first
    runpy.run_module('rbd_ros.node', run_name='__main__', alter_sys=True)


if __name__ == '__main__':
    _preload()
    child_request = _serve()
    if child_request is not None:
        _run_node(child_request)
