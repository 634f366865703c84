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
"""Moved to :mod:`rbd_ros.bag.replay`; kept for this release (see CHANGELOG.rst)."""

import warnings

from rbd_ros.bag.replay import *  # noqa: F401,F403

warnings.warn('rbd_ros.replay moved to rbd_ros.bag.replay'
              '; the old path goes in the next release',
              DeprecationWarning, stacklevel=2)

if __name__ == '__main__':  # python -m rbd_ros.replay, as in the last release
    raise SystemExit(main())  # noqa: F405 - main comes with the star import
