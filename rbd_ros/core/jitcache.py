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
Where numba caches the compiled kernels: a private per-user directory, never the package.

numba loads its on-disk cache with :mod:`pickle`, so whoever can write the cache directory can
run code as whoever imports :mod:`rbd_ros.core`. The cache therefore lives in
``$NUMBA_CACHE_DIR`` if the user set it, else ``$XDG_CACHE_HOME/rbd_ros/numba`` (an absolute
``XDG_CACHE_HOME``), else ``~/.cache/rbd_ros/numba``; directories we create get mode 0700. A
directory not owned by the current user or writable by group or others is refused: the kernels
are then compiled in memory at every start (:data:`CACHE_DIR` is None, :data:`PROBLEM` says
why, and a warning goes to the ``rbd_ros`` logger). numba's default, ``__pycache__`` next to the
installed sources, is never used.

:func:`configure` runs when :mod:`rbd_ros.core.kernels` is imported, before numba decorates
anything (numba picks the cache location when a function is decorated).
"""

import logging
import os
import stat
import sys

_LOG = logging.getLogger('rbd_ros')

#: The cache directory in use, or None (no on-disk cache); set by :func:`configure`.
CACHE_DIR = None
#: Why the cache is off (one line), or None.
PROBLEM = None


def default_dir(environ=None):
    """Return ``$XDG_CACHE_HOME/rbd_ros/numba`` or ``~/.cache/rbd_ros/numba``."""
    environ = os.environ if environ is None else environ
    base = environ.get('XDG_CACHE_HOME', '')
    if not os.path.isabs(base):  # the XDG spec: a relative value is to be ignored
        base = os.path.join(os.path.expanduser('~'), '.cache')
    return os.path.join(base, 'rbd_ros', 'numba')


def unsafe_reason(path):
    """Return why directory ``path`` must not hold a pickle-loaded cache, or None if it is ok."""
    try:
        info = os.stat(path)
    except OSError as exc:
        return f'cannot stat it ({exc.strerror})'
    if not stat.S_ISDIR(info.st_mode):
        return 'not a directory'
    if info.st_uid != os.getuid():
        return f'owned by uid {info.st_uid}, not by this user (uid {os.getuid()})'
    if info.st_mode & (stat.S_IWGRP | stat.S_IWOTH):
        return f'writable by group or others (mode {stat.S_IMODE(info.st_mode):04o})'
    return None


def configure(environ=None, subdir=None):
    """
    Choose numba's cache directory (see the module docstring); return it, or None if refused.

    :param subdir: a directory below it to use instead (created and checked the same way).

    Sets ``NUMBA_CACHE_DIR`` in ``environ`` (numba re-reads its configuration from the
    environment when it compiles) and ``numba.config.CACHE_DIR`` if numba is already imported.
    """
    global CACHE_DIR, PROBLEM
    environ = os.environ if environ is None else environ
    user_set = bool(environ.get('NUMBA_CACHE_DIR'))
    path = os.path.abspath(environ['NUMBA_CACHE_DIR'] if user_set else default_dir(environ))
    # Our own directories: the leaf, and for the default also <cache>/rbd_ros above it (whoever
    # owns a parent can swap the leaf).
    ours = [path] if user_set else [os.path.dirname(path), path]
    # A process started by one that imported rbd_ros inherits its NUMBA_CACHE_DIR, which
    # already ends in ``subdir``: nesting it again gave the child a cache of its own, so a node
    # started from Python (a test, a launch script) compiled for minutes on every new checkout.
    if subdir and os.path.basename(path) != subdir:
        path = os.path.join(path, subdir)
        ours.append(path)
    problem = None
    for directory in ours:  # outermost first: nothing is created below a refused directory
        try:
            os.makedirs(directory, mode=0o700, exist_ok=True)
            problem = unsafe_reason(directory)
        except OSError as exc:
            problem = f'cannot create it ({exc.strerror})'
        if problem:
            problem = f'numba cache directory {directory}: {problem}; compiling the physics ' \
                      'kernels in memory at every start (no on-disk cache)'
            break
    CACHE_DIR, PROBLEM = (None, problem) if problem else (path, None)
    if problem:
        _LOG.warning(problem)
        return None
    environ['NUMBA_CACHE_DIR'] = path
    if 'numba.core.config' in sys.modules:
        sys.modules['numba.core.config'].CACHE_DIR = path
    return path


def kernels_on_disk(contact=False):
    """
    Return True when the step kernel is in the on-disk cache, so a start will not compile.

    Asks numba's own cache of :func:`rbd_ros.core.kernels.advance` (the kernel the simulator
    steps with; the helpers are inlined into it), and with ``contact`` also that of the contact
    step :func:`rbd_ros.core.contact.step.world_step`, whether its index file holds entries for
    the source as it is now: numba's own test (its version and the source's modification time
    and size, stored in the index), not a guess from file times, which a checkout or a copy
    that keeps modification times can fool. Reads the index only; compiles nothing.
    """
    from rbd_ros.core import kernels
    if CACHE_DIR is None:
        return False
    found = _indexed(kernels.advance)
    if contact:
        from rbd_ros.core.contact import step
        found = found and _indexed(step.world_step)
    return found


def _indexed(dispatcher):
    """Tell whether numba's on-disk index of ``dispatcher`` has entries for today's source."""
    try:
        return bool(dispatcher._cache._cache_file._load_index())
    except Exception:  # a numba without these internals, or an index it cannot read
        return False
