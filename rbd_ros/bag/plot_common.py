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
What every ``plot`` figure shares: the last run, panel notes and summaries, title, backend.

The messages of the recording's last run (:func:`last_run`), the refusal of a recording with no
sample to draw, a note in an empty panel, the panels' summaries the figures return, the
figure's title and layout, matplotlib on the Agg backend.

Neighbours: the figures :mod:`rbd_ros.bag.plot_body` (one body), :mod:`rbd_ros.bag.plot_world`
(a world of bodies) and :mod:`rbd_ros.bag.plot_joints` (a robot's or a world's joints); the
command is :mod:`rbd_ros.bag.plot`.
"""

import os
from typing import Any, Dict, Iterator, List, Optional, Tuple

import numpy as np
from rbd_ros.bag.reader import RawMessage, run_starts
from rbd_ros.bag.recording import Bag
from rbd_ros.core import RbdError
from rbd_ros.msgs import type_names as types


def last_run(bag: Bag, topics: List[str]) -> Iterator[Tuple[RawMessage, Any]]:
    """
    Yield ``(raw, decoded)`` of ``topics`` from the last run of the recording only.

    A plot keyed by sim time would otherwise draw the runs between ``~/reset`` calls over
    each other (a later run's samples in place of an earlier one's, the rest of that one
    after them); :func:`finish_figure` says how many runs there were.
    """
    start = ([0] + run_starts(bag.messages(topics)))[-1]  # a first pass: nothing kept
    for index, item in enumerate(bag.decoded_messages(topics)):
        if index >= start:
            yield item


def check_samples(bag: Bag, times: List[int], topics: List[str]) -> None:
    """Refuse a recording without a sample to plot (an empty figure would say nothing)."""
    if not len(times):
        raise RbdError(f'{bag.mcap_path}: no recorded samples to plot on {sorted(topics)} '
                       '(a recording cut off before its first chunk was complete holds none)')


def note_panel(ax: Any, text: str) -> str:
    """Write ``text`` in the middle of an empty panel; return it."""
    ax.text(0.5, 0.5, text, ha='center', va='center', transform=ax.transAxes)
    return text


def panel_summaries(axes: Any, notes: List[Optional[str]]) -> List[Dict[str, Any]]:
    """Describe each laid-out panel: title, box, every curve's data, note."""
    return [{'title': ax.get_title(), 'box': tuple(ax.get_position().extents),
             'lines': {line.get_label(): (np.asarray(line.get_xdata(), dtype=float),
                                          np.asarray(line.get_ydata(), dtype=float))
                       for line in ax.get_lines()},
             'note': note} for ax, note in zip(axes, notes)]


def finish_figure(fig: Any, bag: Bag, title: Optional[str]) -> None:
    """Title the figure (the bag's name, and whether it was finalised); lay it out."""
    status = '' if bag.finalised else '  [not finalised]'
    # /diagnostics comes by wall time: paused at t = 0 it repeats t = 0 without a reset
    runs = len(run_starts(bag.messages(
        [t for t, info in bag.topics.items() if info.type_name != types.DIAGNOSTIC_ARRAY]))) + 1
    if runs > 1:
        status += f'  [the last of {runs} runs: ~/reset]'
    fig.suptitle(title or f'{os.path.basename(os.path.normpath(bag.path))}{status}')
    fig.tight_layout()


def agg_pyplot() -> Any:
    """Return ``matplotlib.pyplot`` on the Agg backend (no display needed)."""
    import matplotlib
    matplotlib.use('Agg')
    from matplotlib import pyplot
    return pyplot
