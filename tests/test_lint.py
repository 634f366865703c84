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

"""The ament linters (flake8, pep257) and the licence header over every Python file."""

import ast
from pathlib import Path

from ament_flake8.main import main_with_errors
from ament_pep257.main import main as pep257_main

REPO = Path(__file__).resolve().parents[1]
PATHS = [str(REPO / 'rbd_ros'), str(REPO / 'tests'), str(REPO / 'launch'),
         str(REPO / 'setup.py')]


def python_files():
    files = [REPO / 'setup.py']
    for top in ('rbd_ros', 'tests', 'launch'):
        files += sorted(p for p in (REPO / top).rglob('*.py') if '__pycache__' not in p.parts)
    return files


def test_flake8():
    rc, errors = main_with_errors(argv=PATHS)
    assert rc == 0, f'Found {len(errors)} code style errors / warnings:\n' + '\n'.join(errors)


def test_pep257():
    assert pep257_main(argv=PATHS) == 0, 'Found code style errors / warnings'


def test_every_python_file_starts_with_the_apache_header():
    header = (REPO / '.ci' / 'header.txt').read_text()
    assert 'Apache License, Version 2.0' in header
    files = python_files()
    assert len(files) > 10
    missing = [str(p.relative_to(REPO)) for p in files if not p.read_text().startswith(header)]
    assert not missing, f'files without the header of .ci/header.txt: {missing}'


def test_every_python_file_says_what_it_is_right_after_the_header():
    """
    After the licence header comes the module docstring, nothing else (no comment, no import).

    The header stays the full Apache text rather than an ``SPDX-License-Identifier`` line:
    ament_copyright identifies a licence by finding its header template's text in the file's
    first comment block, and an SPDX line alone matches no template.
    """
    header = (REPO / '.ci' / 'header.txt').read_text()
    wrong = []
    for path in python_files():
        rest = path.read_text()[len(header):].lstrip('\n')
        tree = ast.parse(path.read_text())
        doc = ast.get_docstring(tree)
        if not (rest.startswith(('"""', "'''", 'r"""')) and doc and doc.strip()):
            wrong.append(str(path.relative_to(REPO)))
    assert not wrong, f'files whose docstring does not follow the header: {wrong}'
