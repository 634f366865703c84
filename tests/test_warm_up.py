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
The test session adopts the kernel warm-up ``.ci/setup`` started beside pip (``.ci/run``).

``AdoptedWarmUp`` follows a process that is not its child: alive while ``/proc`` shows it
running, output from its log as it grows, exit status from the file ``rbd_ros.core.warmup
--status-file`` writes. Shown on stand-in processes (their command lines name the warm-up
module, as the adoption checks) and on the warm-up's own ``main`` with its compile replaced:
no kernel compiles here.
"""

import pathlib
import subprocess
import sys
import time

from conftest import AdoptedWarmUp, finish_warm_up
import pytest
from rbd_ros.core import warmup

# A stand-in warm-up: its command line names the module (argv after -c), it prints a line a
# kind, then writes its status file (argv[2]) and exits with that status (argv[3]).
STAND_IN = """
import sys, time
for kind in ('free', 'contact', 'joints'):
    print(kind, 'kernels ready', flush=True)
    time.sleep(0.3)
if sys.argv[3] != 'hang':
    open(sys.argv[2], 'w').write(sys.argv[3] + '\\n')
    sys.exit(int(sys.argv[3]))
time.sleep(600)
"""


def _stand_in(tmp_path, status, monkeypatch):
    """Start a stand-in as .ci/setup starts the warm-up; return (process, stem) to adopt."""
    stem = tmp_path / 'warm-up'
    with open(f'{stem}.log', 'w') as log:
        process = subprocess.Popen([sys.executable, '-c', STAND_IN, 'rbd_ros.core.warmup',
                                    f'{stem}.status', status], stdout=log,
                                   stderr=subprocess.STDOUT)
    (tmp_path / 'warm-up.pid').write_text(f'{process.pid}\n')
    monkeypatch.setenv('RBD_TEST_ADOPT_WARM_UP', str(stem))
    # its first line: it runs the stand-in (until exec, /proc shows this process's command)
    deadline = time.monotonic() + 30.0
    while not pathlib.Path(f'{stem}.log').read_text() and time.monotonic() < deadline:
        time.sleep(0.05)
    return process, stem


@pytest.mark.parametrize('status', ['0', '3'])
def test_the_adopted_warm_up_gives_its_lines_and_its_status(tmp_path, monkeypatch, status):
    process, _ = _stand_in(tmp_path, status, monkeypatch)
    try:
        adopted = AdoptedWarmUp.adopt()
        assert adopted is not None and adopted.pid == process.pid
        assert adopted.poll() is None  # running
        # finish_warm_up reads its lines as they come and sees its end although no one reaps
        # it until after (a zombie, as the orphan of .ci/setup may stay)
        returned, out = finish_warm_up(adopted)
    finally:
        process.kill()
        process.wait()
    assert returned == int(status)
    assert out.splitlines() == [f'{k} kernels ready' for k in ('free', 'contact', 'joints')]


def test_a_hung_adopted_warm_up_is_killed_and_reads_as_killed(tmp_path, monkeypatch):
    process, _ = _stand_in(tmp_path, 'hang', monkeypatch)
    try:
        adopted = AdoptedWarmUp.adopt()
        time.sleep(1.2)  # its three lines are written
        adopted.kill()
        process.wait(10)  # reaped (a zombie would read as ended all the same)
        assert adopted.wait() == -9
        assert adopted.communicate()[0].count('kernels ready') == 3
    finally:
        process.kill()
        process.wait()


def test_nothing_is_adopted_without_a_live_warm_up(tmp_path, monkeypatch):
    monkeypatch.delenv('RBD_TEST_ADOPT_WARM_UP', raising=False)
    assert AdoptedWarmUp.adopt() is None
    # a pid file naming a process that is not the warm-up (this test's own pid)
    (tmp_path / 'warm-up.pid').write_text(f'{subprocess.os.getpid()}\n')
    (tmp_path / 'warm-up.log').write_text('')
    monkeypatch.setenv('RBD_TEST_ADOPT_WARM_UP', str(tmp_path / 'warm-up'))
    assert AdoptedWarmUp.adopt() is None
    # no pid file at all
    monkeypatch.setenv('RBD_TEST_ADOPT_WARM_UP', str(tmp_path / 'nothing'))
    assert AdoptedWarmUp.adopt() is None


@pytest.mark.parametrize('fails', [False, True])
def test_the_warm_up_writes_its_status_file(tmp_path, monkeypatch, fails):
    def compile_kernels(kinds):
        assert kinds == warmup.KINDS  # --batch: every kind
        if fails:
            raise RuntimeError('a compile failed')
    monkeypatch.setattr(warmup, 'compile_kernels', compile_kernels)
    status = tmp_path / 'status'
    if fails:
        with pytest.raises(RuntimeError):
            warmup.main(['--batch', '--status-file', str(status)])
    else:
        assert warmup.main(['--batch', '--status-file', str(status)]) == 0
    assert status.read_text() == ('1\n' if fails else '0\n')
