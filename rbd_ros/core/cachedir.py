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
The one rule for rbd_ros's cache folders: where they are, who may own them, their mode.

``$XDG_CACHE_HOME/rbd_ros/<name>`` when ``XDG_CACHE_HOME`` is an absolute path (the XDG base
directory spec: a relative value is to be ignored), else ``~/.cache/rbd_ros/<name>``. Every
folder rbd_ros uses there (``rbd_ros`` itself and the leaf) gets mode 0700 (one of ours that is
readable by others is tightened), and one that is not owned by this user or is writable by
group or others is refused (something may already have been put there): what a cache holds is
trusted when it is read (numba loads its cache with :mod:`pickle`; the SDF cache and the meshes
attached to bags are read back as physics), so whoever could write the folder could run code or
change results. The users: the numba kernel cache (:mod:`rbd_ros.core.jitcache`), the SDF cache
(:mod:`rbd_ros.core.contact.mesh_shapes`) and replay's copies of a bag's meshes
(:mod:`rbd_ros.bag.replay_setup`). Nothing here runs at import.
"""

import os
import stat
from typing import Mapping, Optional, Tuple

#: The folder below the user's cache folder that holds every rbd_ros cache.
APP_DIR = 'rbd_ros'


def base_dir(environ: Optional[Mapping[str, str]] = None) -> str:
    """Return ``$XDG_CACHE_HOME/rbd_ros`` (if absolute) or ``~/.cache/rbd_ros``."""
    environ = os.environ if environ is None else environ
    base = environ.get('XDG_CACHE_HOME', '')
    if not os.path.isabs(base):
        base = os.path.join(os.path.expanduser('~'), '.cache')
    return os.path.join(base, APP_DIR)


def unsafe_reason(path: str) -> Optional[str]:
    """Return why directory ``path`` must not hold a cache, or None if it may."""
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


def make_private(directories) -> Optional[Tuple[str, str]]:
    """
    Create each of ``directories`` (outermost first) with mode 0700, check it, tighten it.

    :returns: None if every one may hold a cache, else ``(directory, why not)`` of the first
        refused (nothing is created below it).
    """
    for directory in directories:
        try:
            os.makedirs(directory, mode=0o700, exist_ok=True)
            problem = unsafe_reason(directory)
            if problem is None and stat.S_IMODE(os.stat(directory).st_mode) != 0o700:
                os.chmod(directory, 0o700)
        except OSError as exc:
            problem = f'cannot create it ({exc.strerror})'
        if problem:
            return directory, problem
    return None


def private_dir(name: str, environ: Optional[Mapping[str, str]] = None
                ) -> Tuple[str, Optional[str]]:
    """
    Return ``(folder, None)`` for the cache ``name``, created and checked, or ``(folder, why)``.

    ``why`` is one line naming the refused directory and the reason; the caller then works
    without that cache (and says so).
    """
    base = base_dir(environ)
    folder = os.path.join(base, name)
    refused = make_private((base, folder))
    if refused is None:
        return folder, None
    return folder, f'cache directory {refused[0]}: {refused[1]}'
