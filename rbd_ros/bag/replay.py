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
Replay a recording and check that the simulator reproduces it (``ros2 run rbd_ros replay``).

The recording holds the node's parameters (MCAP metadata record ``rbd_ros``), every wrench as it
took effect (log time = sim time of the start of the step it was applied at) and the output
samples (``pose``, ``twist``, ``odom``, ``/clock``, a robot's ``joint_states``, ``odom`` and
``joint_wrenches``, a world's ``joint_states`` and ``joint_wrenches``; log time = sim time of
the sample).  Replay
rebuilds :class:`rbd_ros.sim.config.NodeConfig` from the stored parameters; a :class:`Replayer`
drives a fresh :class:`rbd_ros.sim.session.SimSession` to each recorded time, submits each recorded
wrench so that it takes effect at the step starting at its recorded time, recomputes every
recorded output through :mod:`rbd_ros.msgs.conversions` and compares it field by field with the
recorded message.

The inputs are checked too: replay digests the wrenches that took effect
(:class:`rbd_ros.sim.session.AppliedDigest`) and compares with the digest the node stored in the
``rbd_ros.run`` record, bit for bit.  Each run between ``~/reset`` calls is replayed and
judged on its own: one that hit a non-finite step must fail again at the same sim time with the
same message (reproduced, a match), and the runs after its reset are compared all the same.
Log times are checked against the recorded configuration before any stepping
(:func:`rbd_ros.bag.replay_setup.check_times`), so a crafted bag cannot make replay step
without bound.

By default the comparison is bit-exact (every float identical to the last bit, stamps and frame
ids equal).  ``--tolerance`` relaxes it to ``error <= tolerance`` for each of: position (m,
Euclidean norm of the difference), orientation (rad, geodesic angle between the quaternions),
linear velocity (m/s) and angular velocity (rad/s).  ``--integrator`` and ``--timestep`` replay
with another integrator or step and report how far the result moves from the recording (an
accuracy study from one recording); samples then fall on the first step end at or after their
recorded time.

Messages are decoded with the schemas stored in the file (``mcap-ros2-support``); rclpy is not
imported.  Exit status: 0 match, 1 mismatch, 2 the bag cannot be replayed (missing, empty,
truncated before any data, corrupt, foreign, over the limits of :mod:`rbd_ros.sim.limits`: one line
on stderr, never a traceback), 3 the replay matches a recorded run that failed (a non-finite
step reproduced, or the node's process ended with an exception): never ``MATCH`` for a run
that did not end as it should; 141 the reader closed the pipe (``replay --json bag | head``:
no traceback).

This module is the command and :func:`replay_bag`; the stages are its neighbours:
:mod:`rbd_ros.bag.replay_setup` (the stored configuration, which topic is which, the time
checks), :mod:`rbd_ros.bag.replayer` (the :class:`Replayer` and its loop over runs),
:mod:`rbd_ros.bag.replay_compare` (how a sample, a failure and the wrench digest are judged),
:mod:`rbd_ros.bag.replay_result` (what a replay found, and its summary). Their public names
are importable from here too.
"""

import argparse
import json
import os
import sys
from typing import List, Optional, Union

from rbd_ros.bag.cli import open_bag_with_notes, run_on_bag
from rbd_ros.bag.recording import Bag, open_bag
from rbd_ros.bag.replay_compare import expected_message  # noqa: F401
from rbd_ros.bag.replay_result import format_summary, ReplayResult, TopicResult  # noqa: F401
from rbd_ros.bag.replay_setup import (check_times, command_payload, COMMAND_TYPES,  # noqa: F401
                                      config_from_bag, OUTPUT_KINDS, POINT_TYPE,
                                      recorded_failure, ReplayError, WRENCH_TYPE)
from rbd_ros.bag.replayer import Replayer
from rbd_ros.sim import limits

#: Exit status: every sample and wrench matched.
EXIT_MATCH = 0
#: Exit status: something differs (:attr:`ReplayResult.problems`).
EXIT_MISMATCH = 1
#: Exit status: the replay matches, but the recorded run failed (:attr:`ReplayResult.run_failed`).
EXIT_RUN_FAILED = 3


def replay_bag(bag: Union[str, os.PathLike, Bag], *, tolerance: Optional[float] = None,
               integrator: Optional[str] = None, timestep_s: Optional[float] = None,
               progress: bool = False) -> ReplayResult:
    """
    Replay ``bag`` (a path or an opened :class:`rbd_ros.bag.recording.Bag`) and compare.

    :param tolerance: None = bit-exact; else the largest accepted error (m, rad, m/s, rad/s).
    :param integrator: replay with this integrator instead of the recorded one.
    :param timestep_s: replay with this physics step instead of the recorded one, s.
    :param progress: draw a progress bar on stderr.
    :returns: a :class:`ReplayResult`.
    :raises RbdError: the bag cannot be read (:class:`RecordingError`) or replayed at all
        (:class:`ReplayError`, or the stored configuration is invalid).
    """
    if not isinstance(bag, Bag):
        limits.check_mcap_chunks(bag)
        bag = open_bag(bag)
        limits.check_bag(bag, steps=False)
    replayer = Replayer(bag, tolerance=tolerance, integrator=integrator, timestep_s=timestep_s)
    messages = replayer.recorded_messages()
    if messages is not None:
        replayer.run(messages, progress)
    return replayer.result


def build_parser() -> argparse.ArgumentParser:
    """Return the argument parser of the ``replay`` executable."""
    parser = argparse.ArgumentParser(
        prog='replay',
        description='Replay an rbd_ros recording and compare the recomputed outputs with the '
                    'recorded ones (exit 0 match, 1 mismatch, 2 unreadable bag or over the limits '
                    'of rbd_ros.sim.limits, 3 the replay matches but the recorded run failed: a '
                    'non-finite step or an exception).')
    parser.add_argument('bag', help='bag directory or .mcap file')
    parser.add_argument('--tolerance', type=float, default=None,
                        help='accept errors up to this (m, rad, m/s, rad/s); default bit-exact')
    parser.add_argument('--integrator', default=None,
                        help='replay with this integrator (accuracy study)')
    parser.add_argument('--timestep', type=float, default=None, metavar='SECONDS',
                        help='replay with this physics step in s (accuracy study)')
    parser.add_argument('--json', action='store_true', help='print the result as JSON')
    bar = parser.add_mutually_exclusive_group()
    bar.add_argument('--progress', dest='progress', action='store_true', default=None,
                     help='draw a progress bar on stderr (default: when stderr is a TTY)')
    bar.add_argument('--no-progress', dest='progress', action='store_false')
    return parser


def main(argv: Optional[List[str]] = None) -> int:
    """Run the ``replay`` executable; return the exit status."""
    args = build_parser().parse_args(argv)
    progress = args.progress if args.progress is not None else sys.stderr.isatty()

    def run():
        if args.tolerance is not None and not args.tolerance >= 0.0:
            raise ReplayError(f'--tolerance {args.tolerance}: must be >= 0')
        bag = open_bag_with_notes('replay', args.bag, steps=False)
        return replay_bag(bag, tolerance=args.tolerance, integrator=args.integrator,
                          timestep_s=args.timestep, progress=progress)

    status, result = run_on_bag('replay', args.bag, 'replayed', run)
    if status:
        return status
    try:
        print(json.dumps(result.to_dict(), indent=2) if args.json else format_summary(result),
              flush=True)
    except BrokenPipeError:
        # `replay --json bag | head` closed the pipe: the Python recipe (stdout to devnull,
        # so the flush at exit cannot raise again), and 141 = 128 + SIGPIPE, the status of a
        # C tool the closed pipe ended (what `set -o pipefail` users see from `cat`).
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 141
    if not result.match:
        return EXIT_MISMATCH
    return EXIT_RUN_FAILED if result.run_failed else EXIT_MATCH


def entry_point() -> None:
    """Console-script entry point: exit with :func:`main`'s status."""
    sys.exit(main())


if __name__ == '__main__':
    entry_point()
