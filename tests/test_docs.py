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
The README is one page and ``doc/`` the reference: their structure and their links, checked.

What the brief and issue 25 ask of the README: its title, one line of what the package is, then
(its first code block) exactly the two commands; short enough to read on a screen; every link in
it and in ``doc/`` points at a file (and heading) that exists; facts that the tree decides (which
parameter files and bags there are) match the tree.
"""

from pathlib import Path
import re

REPO = Path(__file__).resolve().parents[1]
README = REPO / 'README.md'
DOCS = sorted((REPO / 'doc').glob('*.md'))
#: A page a newcomer reads without scrolling much: two screens of 50 lines.
README_MAX_LINES = 100
LINK = re.compile(r'\[[^\]]*\]\(([^)\s]+)\)')


def _code_blocks(text):
    return re.findall(r'```[a-z]*\n(.*?)```', text, re.S)


def _anchor(heading):
    """Return the anchor GitHub and rosdoc2's Markdown give ``heading``."""
    slug = re.sub(r'[^\w\- ]', '', heading.strip().lower())
    return slug.replace(' ', '-')


def test_the_readme_opens_with_its_title_one_line_and_the_two_commands():
    lines = README.read_text(encoding='utf-8').splitlines()
    assert lines[0].startswith('# rbd_ros'), lines[0]
    assert lines[1] == '' and lines[2] and lines[3] == '', 'one line of what it is'
    assert lines[4] == '```bash', 'the first code block follows that line'
    commands = _code_blocks(README.read_text(encoding='utf-8'))[0].splitlines()
    assert len(commands) == 2, commands
    assert commands[0].startswith('bash .ci/setup && .venv/bin/python -m rbd_ros.demo')
    assert commands[1].startswith('bash .ci/run')


def test_ci_runs_the_readmes_test_command():
    run = (REPO / '.ci' / 'run').read_text(encoding='utf-8')
    assert 'python" -m pytest tests' in run


def test_the_readme_fits_on_a_screen_or_two():
    lines = README.read_text(encoding='utf-8').splitlines()
    assert len(lines) <= README_MAX_LINES, len(lines)
    for heading in ('## A 30-second tour', '## What it does', '## What it does not do (yet)'):
        assert heading in lines, heading


def test_every_link_resolves_to_a_file_and_heading_that_exist():
    broken = []
    for page in [README] + DOCS:
        for target in LINK.findall(page.read_text(encoding='utf-8')):
            if re.match(r'[a-z]+://', target):
                continue
            path, _, anchor = target.partition('#')
            file = (page.parent / path).resolve() if path else page
            if not file.exists():
                broken.append(f'{page.name}: {target}')
            elif anchor and file.suffix == '.md':
                anchors = {_anchor(h) for h in re.findall(r'^#+ (.*)$', file.read_text(
                    encoding='utf-8'), re.M)}
                if anchor not in anchors:
                    broken.append(f'{page.name}: {target} (no such heading)')
    assert not broken, broken


def test_every_doc_page_is_linked_from_the_index_and_the_readme():
    index = (REPO / 'doc' / 'index.md').read_text(encoding='utf-8')
    readme = README.read_text(encoding='utf-8')
    for page in DOCS:
        if page.name == 'index.md':
            continue
        assert f']({page.name})' in index, page.name
        assert f'](doc/{page.name})' in readme, page.name


def test_every_parameter_file_is_listed_in_getting_started():
    page = (REPO / 'doc' / 'getting-started.md').read_text(encoding='utf-8')
    listed = set(re.findall(r'^\| `([\w.]+\.yaml)` \|', page, re.M))
    assert listed == {p.name for p in (REPO / 'msg_config').glob('*.yaml')}


def test_the_recording_page_counts_the_reference_bags():
    words = {3: 'three', 4: 'four', 5: 'five', 6: 'six', 7: 'seven', 8: 'eight', 9: 'nine',
             10: 'ten', 11: 'eleven', 12: 'twelve'}
    bags = [d for d in (REPO / 'bags').iterdir() if d.is_dir()]
    page = (REPO / 'doc' / 'recording.md').read_text(encoding='utf-8')
    assert f'`bags/` holds {words[len(bags)]} recordings' in page


def test_the_changelog_is_in_ros_format():
    lines = (REPO / 'CHANGELOG.rst').read_text(encoding='utf-8').splitlines()
    assert lines[1] == 'Changelog for package rbd_ros'
    assert set(lines[0]) == {'^'} and lines[0] == lines[2]
    headings = [lines[i - 1] for i, line in enumerate(lines)
                if line and set(line) == {'-'} and i > 0]
    release = re.compile(r'\d+\.\d+\.\d+ \(\d{4}-\d\d-\d\d\)$')
    assert headings[0] == 'Forthcoming' or release.match(headings[0]), headings[0]
    for heading in headings[1:]:
        assert release.match(heading), heading


def test_the_recording_page_names_every_run_record_key_and_ending():
    """doc/recording.md lists the ``rbd_ros.run`` record: every key and every ``ended_by``."""
    from rbd_ros.bag.recorder import ENDINGS, RUN_KEYS
    text = (REPO / 'doc' / 'recording.md').read_text()
    missing = [name for name in RUN_KEYS + ENDINGS if f'`{name}`' not in text]
    assert not missing, f'doc/recording.md does not name {missing}'
