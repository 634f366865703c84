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

"""The ``ros`` fixture of the node tests: a test-side rclpy node in its own context."""

import pytest
import rclpy
from rclpy.executors import SingleThreadedExecutor


@pytest.fixture(name='ros')
def ros_fixture(request):
    """Yield a test-side rclpy node (named after the test module) and its executor."""
    context = rclpy.Context()
    context.init()
    name = request.module.__name__.rsplit('.', 1)[-1].replace('test_', '', 1) + '_talker'
    node = rclpy.create_node(name, context=context)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    yield node, executor
    executor.shutdown()
    node.destroy_node()
    context.try_shutdown()
