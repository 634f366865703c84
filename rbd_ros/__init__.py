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

"""rbd_ros: rigid body dynamics for ROS 2 Jazzy."""

from importlib import metadata
from pathlib import Path
from xml.etree import ElementTree


def _version():
    """
    Return the version of this copy of rbd_ros; package.xml is the one place it is written.

    The installed metadata (made by setup.py from package.xml) when it describes this very
    file; else (a source checkout, or ``colcon build --symlink-install``) the package.xml beside
    the package directory; ``'0+unknown'`` when there is neither.
    """
    here = Path(__file__).resolve()
    try:
        dist = metadata.distribution('rbd_ros')
        if Path(dist.locate_file('rbd_ros/__init__.py')).resolve() == here:
            return dist.version
    except metadata.PackageNotFoundError:
        pass
    package_xml = here.parents[1] / 'package.xml'
    if package_xml.is_file():
        return ElementTree.parse(package_xml).findtext('version')
    return '0+unknown'


__version__ = _version()
