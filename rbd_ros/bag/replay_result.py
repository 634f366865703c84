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
What a replay found: per topic (:class:`TopicResult`), per run (:class:`ReplayResult`), as text.

:class:`rbd_ros.bag.replayer.Replayer` fills them; ``replay`` prints :func:`format_summary`, or
``--json`` :meth:`ReplayResult.to_dict`. Errors are maxima over a topic's samples, each in its
field's unit; ``match`` (every sample and wrench identical, or within the tolerance, and no
problem) decides the exit status.
"""

import dataclasses
from typing import Any, Dict, List, Optional


@dataclasses.dataclass
class TopicResult:
    """
    Comparison results of one recorded topic.

    Errors are maxima over the samples: position in m, orientation in rad, linear velocity in
    m/s, angular velocity in rad/s (None when the topic has no such field).
    """

    topic: str
    kind: str
    samples: int = 0
    mismatches: int = 0
    bit_exact: bool = True
    max_position_error_m: Optional[float] = None
    max_orientation_error_rad: Optional[float] = None
    max_linear_velocity_error_m_s: Optional[float] = None
    max_angular_velocity_error_rad_s: Optional[float] = None
    max_force_error_n: Optional[float] = None
    max_torque_error_nm: Optional[float] = None
    max_joint_position_error: Optional[float] = None  # rad or m, norm over the joints
    max_joint_velocity_error: Optional[float] = None  # rad/s or m/s
    max_joint_effort_error: Optional[float] = None  # N m or N
    first_mismatch: Optional[str] = None

    def take_error(self, name: str, value: float) -> None:
        """Raise the maximum error ``name`` (one of the ``max_*`` fields) to ``value``."""
        current = getattr(self, name)
        setattr(self, name, value if current is None else max(current, value))


@dataclasses.dataclass
class ReplayResult:
    """The outcome of :func:`replay_bag` (:class:`Replayer`); ``match`` decides the exit status."""

    bag: str
    finalised: bool
    notes: List[str]
    integrator: str
    timestep_ns: int
    recorded_integrator: str
    recorded_timestep_ns: int
    tolerance: Optional[float]
    topics: Dict[str, TopicResult]
    wrenches: int = 0
    wrench_mismatches: int = 0
    wrench_digest_checked: bool = False
    failure_reproduced: Optional[str] = None
    run_crashed: Optional[str] = None
    remarks: List[str] = dataclasses.field(default_factory=list)
    problems: List[str] = dataclasses.field(default_factory=list)
    #: One entry per run (the first, then one per ``~/reset``): ``samples`` compared in it,
    #: ``failure_ns`` the sim time its replay failed at (None: it did not), ``not_replayed``
    #: its recorded messages after that failure.
    runs: List[Dict[str, Any]] = dataclasses.field(default_factory=list)

    @property
    def run_failed(self) -> Optional[str]:
        """Return why the recorded run failed (non-finite step, exception), or None."""
        return self.failure_reproduced or self.run_crashed

    @property
    def compared(self) -> int:
        """Return the number of output samples compared."""
        return sum(t.samples for t in self.topics.values())

    @property
    def match(self) -> bool:
        """Return True when every sample and wrench matched and nothing else went wrong."""
        return (not self.problems and self.wrench_mismatches == 0
                and all(t.mismatches == 0 for t in self.topics.values()))

    def to_dict(self) -> dict:
        """Return a JSON-ready dict."""
        return {
            'bag': self.bag,
            'match': self.match,
            'finalised': self.finalised,
            'notes': list(self.notes),
            'integrator': self.integrator,
            'timestep_ns': self.timestep_ns,
            'recorded_integrator': self.recorded_integrator,
            'recorded_timestep_ns': self.recorded_timestep_ns,
            'tolerance': self.tolerance,
            'samples_compared': self.compared,
            'wrenches': self.wrenches,
            'wrench_mismatches': self.wrench_mismatches,
            'wrench_digest_checked': self.wrench_digest_checked,
            'failure_reproduced': self.failure_reproduced,
            'run_crashed': self.run_crashed,
            'run_failed': self.run_failed is not None,
            'remarks': list(self.remarks),
            'problems': list(self.problems),
            'runs': [dict(run) for run in self.runs],
            'topics': {name: dataclasses.asdict(t) for name, t in self.topics.items()},
        }


#: The errors a summary line shows, in this order: (field, what, unit); a topic shows the ones
#: its kind has (None: not compared for it).
SHOWN_ERRORS = (
    ('max_position_error_m', 'position', 'm'),
    ('max_orientation_error_rad', 'orientation', 'rad'),
    ('max_linear_velocity_error_m_s', 'linear velocity', 'm/s'),
    ('max_angular_velocity_error_rad_s', 'angular velocity', 'rad/s'),
    ('max_force_error_n', 'force', 'N'),
    ('max_torque_error_nm', 'torque', 'N m'),
    ('max_joint_position_error', 'joint position', 'rad or m'),
    ('max_joint_velocity_error', 'joint velocity', 'rad/s or m/s'),
    ('max_joint_effort_error', 'joint effort', 'N m or N'),
)


def largest_errors(topic: TopicResult) -> str:
    """Return the topic's largest errors with their units (``-`` when it has none: clock)."""
    shown = [f'{what} {value:.3g} {unit}' for field, what, unit in SHOWN_ERRORS
             if (value := getattr(topic, field)) is not None]
    return ', '.join(shown) or '-'


def run_line(run: Dict[str, Any]) -> str:
    """Return what one run of :attr:`ReplayResult.runs` did, in words."""
    text = f'{run["samples"]} samples compared'
    if run['failure_ns'] is not None:
        text += f', failed at t = {run["failure_ns"]} ns'
    if run['not_replayed']:
        text += f', {run["not_replayed"]} recorded messages after that not replayed'
    return text


def format_summary(result: ReplayResult) -> str:
    """Return the human-readable per-topic summary as a string."""
    lines = []
    what = 'bit-exact' if result.tolerance is None else f'tolerance {result.tolerance:g}'
    lines.append(f'replay of {result.bag} ({what})')
    if (result.integrator, result.timestep_ns) != (result.recorded_integrator,
                                                   result.recorded_timestep_ns):
        lines.append(f'  recorded with {result.recorded_integrator}, '
                     f'{result.recorded_timestep_ns} ns step; replayed with '
                     f'{result.integrator}, {result.timestep_ns} ns step')
    else:
        lines.append(f'  integrator {result.integrator}, step {result.timestep_ns} ns')
    if not result.finalised:
        lines.append('  NOTE: the bag was not finalised; replaying what it holds')
    lines.append(f'  wrenches: {result.wrenches} recorded, {result.wrench_mismatches} '
                 'mismatched' + ('; applied wrenches checked bit for bit against the digest '
                                 'of the node' if result.wrench_digest_checked else ''))
    if result.failure_reproduced:
        lines.append(f'  failure reproduced: {result.failure_reproduced}')
    if len(result.runs) > 1:
        lines.extend(f'  run {number} of {len(result.runs)}: {run_line(run)}'
                     for number, run in enumerate(result.runs, 1))
    width = max([len('topic')] + [len(t.topic) for t in result.topics.values()])
    lines.append(f'  {"topic":<{width}} {"samples":>8} {"mismatch":>8}  largest errors')
    for t in result.topics.values():
        lines.append(f'  {t.topic:<{width}} {t.samples:>8} {t.mismatches:>8}  '
                     f'{largest_errors(t)}')
        if t.first_mismatch:
            lines.append(f'    first mismatch: {t.first_mismatch}')
    for remark in result.remarks:
        lines.append(f'  note: {remark}')
    for problem in result.problems:
        lines.append(f'  problem: {problem}')
    if result.run_crashed:
        lines.append(f'  run crashed: {result.run_crashed}')
    if not result.match:
        lines.append('MISMATCH')
    elif result.run_failed:
        lines.append('RUN FAILED (the replay matches the recording of a run that failed)')
    else:
        lines.append('MATCH')
    return '\n'.join(lines)
