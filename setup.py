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

from setuptools import find_packages, setup

package_name = 'rbd_ros'

setup(
    name=package_name,
    version='0.1.0',
    packages=find_packages(exclude=['tests', 'tests.*']),
    data_files=[
        ('share/ament_index/resource_index/packages', ['resource/' + package_name]),
        ('share/' + package_name, ['package.xml']),
        ('share/' + package_name + '/msg_config', sorted(glob('msg_config/*.yaml'))),
        ('share/' + package_name + '/msg_config/meshes', sorted(glob('msg_config/meshes/*'))),
    ],
    install_requires=['setuptools'],
    zip_safe=True,
    maintainer='The rbd_ros authors',
    maintainer_email='maintainers@rbd-ros.invalid',
    description='Rigid body dynamics node for ROS 2 Jazzy with MCAP recording and replay.',
    license='Apache-2.0',
    tests_require=['pytest'],
    entry_points={
        'console_scripts': [
            'rigid_body_node = rbd_ros.node:main',
            'replay = rbd_ros.replay:main',
            'plot = rbd_ros.plot:main',
        ],
    },
)
