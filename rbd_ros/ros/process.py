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
The ``rigid_body_node`` process: ``rclpy`` started, the node built, the spin loop, the teardown.

:func:`main` is what ``ros2 run rbd_ros rigid_body_node`` runs (through :mod:`rbd_ros.node`):
our own signal handlers from the start, ``rclpy.init`` with its errors as one line, the
:class:`~rbd_ros.ros.node.RigidBodyNode` built in a worker thread (a signal during the slow part
of start-up leaves at once), the spin loop (:func:`_serve`), and the exit status.
"""

import os
import signal
import sys
import tempfile
import threading
import time

from rbd_ros.core import numba_target, RbdError
from rbd_ros.ros import endpoints
from rbd_ros.ros import participant
from rbd_ros.ros.node import PAST_SLOW_START_UP, RigidBodyNode, say
from rbd_ros.ros.wakeups import QuickLook
from rbd_ros.sim import limits
import rclpy
from rclpy.executors import ExternalShutdownException, ShutdownException
from rclpy.executors import SingleThreadedExecutor, TimeoutException
from rclpy.signals import SignalHandlerOptions

START_UP_POLL_S = 0.05  # how often the main thread looks for a signal during start-up


def _init_rclpy(args):
    """
    ``rclpy.init`` without its own signal handlers; return None, or one line on why it failed.

    rcl refuses a missing or broken params file, mixed int/float arrays and ``-p name:=``
    with an exception plus an ``[ERROR] [rcl]`` log line on stderr: the log is held back and
    the caller prints one line instead.
    """
    saved_fd = os.dup(2)
    with tempfile.TemporaryFile() as log:
        os.dup2(log.fileno(), 2)
        try:
            rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
            error = None
        except RuntimeError as exc:  # RCLError, UnknownROSArgsError
            error = exc
        finally:
            os.dup2(saved_fd, 2)
            os.close(saved_fd)
        if error is None:
            log.seek(0)
            sys.stderr.write(log.read().decode(errors='replace'))
            return None
    text = endpoints.rcl_text(error).replace('. Error: error not set', ': no value after :=')
    if type(error).__name__ == 'UnknownROSArgsError':
        text = f'unknown ROS arguments {text}'
    if 'Sequence should be of same type' in text:
        text += ' (write every value of a double array with a decimal point: 0.0, not 0)'
    return f'bad --ros-args: {text}'


def _serve(executor, node, look):
    """
    One wake-up of the spin loop: one ready callback (or a wait for one), then the steps due.

    What ``executor.spin_once`` does, with the wait timed apart from the callback: the cost of
    a wake-up is the wait set's, not the callback's (a callback that takes long, or an input
    followed by a tick, would otherwise grow the tick budget, and with it the next wait). The
    wait is ``look``'s (a :class:`rbd_ros.ros.wakeups.QuickLook`); the executor is asked only
    when it finds something ready.
    """
    timeout_s = node.seconds_to_next_step()
    start_ns = time.monotonic_ns()
    handler = None
    try:
        if look.anything_ready(int(timeout_s * 1e9)):
            handler, _, _ = executor.wait_for_ready_callbacks(timeout_sec=0)
    except (TimeoutException, ShutdownException):
        handler = None
    if timeout_s == 0:  # no waiting in it: what a wake-up costs
        node.note_wake_up(time.monotonic_ns() - start_ns)
    if handler is not None:
        # The steps due by now first (the loop sleeps through a sample's steps): an input
        # takes effect at the step due when it came, as with a wake-up every step.
        node.tick()
        handler()
        handler.result()  # raises what the callback raised
    node.tick()


def main(args=None):
    """
    Run the node until ``duration_s`` passes or SIGINT/SIGTERM; return the exit status.

    0: ended by ``duration_s`` or a signal (also during start-up); 1: a non-finite step with
    ``duration_s`` set, an exception out of the step loop, or a recording error; 2: bad input
    at start-up. Every ending that the process survives writes the ``rbd_ros.run`` record.
    """
    # Our own signal handlers, from the start: they only note the signal. (rclpy's would shut
    # the context down under a running callback, whose next publish then fails.) The node is
    # built in a worker thread (mesh loading and the first-step check run compiled kernels that
    # release the GIL), so the main thread sees a signal within the wait below and leaves at
    # once during the slow part of start-up (meshes, the first step); once the node runs, a
    # signal stops it between callbacks, then the recording is finalised; once it is final, a
    # signal ends the teardown at once.
    stop = []
    for signum in (signal.SIGINT, signal.SIGTERM):
        signal.signal(signum, lambda signum, _: stop.append(signal.Signals(signum).name))
    numba_target.skip_blas_probe()  # ~0.25 s of CPU a start, for a check no kernel needs
    numba_target.load_without_refresh()  # ~0.17 s of CPU a start, for what only compiles need
    # The participant, created with the node, reads its profile (rbd_ros.ros.participant).
    with participant.node_profile():
        error = _init_rclpy(args)
        if error is not None:
            say(error)
            sys.exit(2)
        built = []

        def build():
            try:
                built.append(RigidBodyNode(args))
            except BaseException as exc:  # handed to the main thread
                built.append(exc)

        worker = threading.Thread(target=build, name='rigid_body_node start-up', daemon=True)
        worker.start()
        while worker.is_alive() and not (stop and not PAST_SLOW_START_UP.is_set()):
            worker.join(START_UP_POLL_S)
    if stop and not built:
        say(f'{stop[0]} during start-up: stopped')
        os._exit(0)  # nothing recorded yet; a half-built node needs no teardown
    node = built[0]
    if isinstance(node, RbdError):
        say(node)
        rclpy.try_shutdown()
        sys.exit(2)
    if isinstance(node, BaseException):
        raise node
    # Not rclpy's experimental EventsExecutor: its event queue is unbounded, so a wrench flood
    # faster than the node grew memory without limit. This one takes at most one message per
    # subscription per wait; what it cannot take, DDS keep-last drops. It rebuilds its wait set
    # at every wake-up, so instead of the half-step tick timer (2 kHz of wake-ups, half a core)
    # the loop waits until the next step is due, or a message or request comes, and then ticks.
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    look = QuickLook(node)
    try:
        while rclpy.ok() and not node.done and not stop:
            _serve(executor, node, look)
    except ExternalShutdownException:
        pass
    except Exception as exc:  # out of a callback or a step: recorded, then exit 1
        node.crashed(exc)
    finally:
        status = node.finish(stop[0] if stop else 'shutdown')
        # The recording is final: a signal during the teardown below ends the process at once.
        for signum in (signal.SIGINT, signal.SIGTERM):
            signal.signal(signum, lambda *_: os._exit(status))
        executor.shutdown()
        if node.endpoint_count() > limits.TEARDOWN_ENDPOINTS or node.compiling():
            # With the recording final there is nothing left to lose, so the process leaves at
            # once (the OS reclaims the rest): Fast DDS deletes endpoints in superlinear time
            # (6,000 publishers: 3.6 s; a world of 1,000 bodies: 18 s), and a signal during a
            # cold start's compile need not wait for numba.
            rclpy.try_shutdown()
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(status)
        node.destroy_node()
        rclpy.try_shutdown()
    sys.exit(status)


if __name__ == '__main__':
    main()
