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

"""Install rbd_ros as an ament_python package (``colcon build``) or with pip."""

from glob import glob
from pathlib import Path
from xml.etree import ElementTree

from setuptools import find_packages, setup

package_name = 'rbd_ros'
# The one version: package.xml's (rbd_ros.__version__ reads the installed metadata made from it).
version = ElementTree.parse(Path(__file__).resolve().parent / 'package.xml').findtext('version')
# Runtime dependencies; lower bounds are the pins of .ci/requirements.txt, the versions tested.
# The ROS packages (rclpy, the message packages, ament_index_python) come from ROS (rosdep, or
# the ros-jazzy-* wheels), not from here: see package.xml.
install_requires = [
    'numpy>=2.4.6',
    'numba>=0.68.1',
    'mcap>=1.6.0',
    'mcap-ros2-support>=0.6.0',
    'rosbags>=0.11.9',
    'matplotlib>=3.11.2',
    'PyYAML>=6.0.3',
    'trimesh>=5.2.0',
    'charset-normalizer>=3.4.7',
    'yourdfpy>=0.0.60',
    'lxml>=6.2.0',
    'xacro>=2.1.1',
]

setup(
    name=package_name,
    version=version,
    packages=find_packages(exclude=['tests', 'tests.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/msg_config', sorted(glob('msg_config/*.yaml'))),
        ('share/' + package_name + '/msg_config/meshes', sorted(glob('msg_config/meshes/*'))),
        ('share/' + package_name + '/msg_config/urdf', sorted(glob('msg_config/urdf/*'))),
        ('share/' + package_name + '/launch', sorted(glob('launch/*.launch.py'))),
        ('share/' + package_name + '/rviz', sorted(glob('rviz/*.rviz'))),
    ],
    install_requires=install_requires,
    zip_safe=True,
    maintainer='The rbd_ros authors',
    maintainer_email='maintainers@rbd-ros.invalid',
    description=('Rigid bodies, worlds with frictional contact and URDF robots for ROS 2 '
                 'Jazzy, recorded to MCAP and replayed bit-exactly.'),
    license='Apache-2.0',
    tests_require=['pytest', 'pytest-xdist'],
    entry_points={
        'console_scripts': [
            'rigid_body_node = rbd_ros.node:main',
            'replay = rbd_ros.bag.replay:main',
            'plot = rbd_ros.bag.plot:main',
        ],
    },
)
