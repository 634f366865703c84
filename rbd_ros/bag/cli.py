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
What the bag tools (``replay``, ``plot``) share on the command line: one stderr line per failure.

Both open a recording named on the command line, print why it is not finalised, and turn every
failure into ``<prog>: error: ...`` on stderr with exit status 2 (130 on Ctrl-C), never a
traceback.
"""

import sys
from typing import Callable, Optional, Tuple, TypeVar

from rbd_ros.bag.recording import Bag, open_bag
from rbd_ros.core import numba_target
from rbd_ros.core.errors import RbdError
from rbd_ros.sim import limits

T = TypeVar('T')

#: Exit status of a bag tool whose bag cannot be read (missing, corrupt, foreign, ...).
EXIT_UNREADABLE = 2
#: Exit status after Ctrl-C.
EXIT_INTERRUPTED = 130


def open_bag_with_notes(prog: str, path: str, steps: bool = True) -> Bag:
    """
    Open the recording ``path`` and print each of its notes as ``<prog>: note: ...``.

    :param steps: also check the steps a replay would take (replay checks them itself).
    :raises RecordingError: also for a recording over the limits of :mod:`rbd_ros.sim.limits`,
        refused before it is parsed or replayed.
    """
    limits.check_mcap_chunks(path)  # before the reader decompresses anything
    bag = open_bag(path)
    limits.check_bag(bag, steps)  # before replay or plot does the work
    for note in bag.notes:
        print(f'{prog}: note: {note}', file=sys.stderr)
    return bag


def run_on_bag(prog: str, bag_path: str, verb: str,
               action: Callable[[], T]) -> Tuple[int, Optional[T]]:
    """
    Run ``action()`` for a command-line tool; every failure becomes one stderr line.

    :param prog: the tool's name, first word of every line it prints.
    :param bag_path: the bag as given on the command line (named in unexpected failures).
    :param verb: what the tool does to a bag, as in ``cannot be <verb>`` (``'replayed'``).
    :returns: ``(status, result)``: 0 and ``action()``'s result; 2 on any error
        (``prog: error: ...``; a corrupt file can fail anywhere in the decoders, so anything is
        caught); 130 on Ctrl-C.
    """
    numba_target.skip_blas_probe()  # ~0.25 s of CPU a run, for a check no kernel needs
    numba_target.load_without_refresh()  # ~0.17 s of CPU a run, for what only compiles need
    try:
        return 0, action()
    except KeyboardInterrupt:
        print(f'{prog}: interrupted', file=sys.stderr)
        return EXIT_INTERRUPTED, None
    except (RbdError, OSError) as exc:
        print(f'{prog}: error: {exc}', file=sys.stderr)
        return EXIT_UNREADABLE, None
    except Exception as exc:  # the one-line promise covers every decoder failure
        print(f'{prog}: error: {bag_path}: cannot be {verb} ({type(exc).__name__}: {exc})',
              file=sys.stderr)
        return EXIT_UNREADABLE, None
