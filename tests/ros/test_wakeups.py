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
The spin loop's quick look (rbd_ros.ros.wakeups) sees what the executor would serve.

Through real Fast DDS, in this process: a node served by the look (two subscriptions, a
service, a timer, publishers with QoS event handlers) and a talker in a context of its own.
A wake-up waits only on the subscriptions that had a publisher or a message at a census; a
census (on a clock the test moves) finds the rest. The look says nothing is ready while
nothing is, waits its timeout, wakes for a message on a watched topic, a request and a timer
well before it, finds at a census a message whose publisher has already gone, and stays
ready until the executor has taken every pending message.
"""

import time

import pytest
from rbd_ros.ros import wakeups
import rclpy
from rclpy.executors import SingleThreadedExecutor
from std_msgs.msg import String
from std_srvs.srv import Trigger

# A wait that a message ends comes back within DDS's delivery on this machine (~1 ms, more
# under load); a wait that nothing ends takes its whole timeout. 2 s against 5 s tells them
# apart on a loaded machine, and 0.2 s is long enough to see a wait that returned at once.
LONG_NS = 5_000_000_000
SHORT_NS = 200_000_000
TOPICS = ('wakeups_a', 'wakeups_b')


class Served:
    """The served node, its look (on a clock the test sets) and executor; the talker."""

    def __init__(self):
        self.contexts = [rclpy.Context(), rclpy.Context()]
        for context in self.contexts:
            context.init()
        self.node = rclpy.create_node('wakeups_served', context=self.contexts[0])
        self.heard = []
        for topic in TOPICS:
            self.node.create_subscription(String, topic, self.heard.append, 10)
        self.node.create_service(Trigger, 'wakeups_trigger', lambda _, response: response)
        self.node.create_publisher(String, 'wakeups_out', 10)  # QoS event handlers: waitables
        self.executor = SingleThreadedExecutor(context=self.contexts[0])
        self.executor.add_node(self.node)
        self.talker = rclpy.create_node('wakeups_talker', context=self.contexts[1])
        self.now_ns = 0
        self.look = wakeups.QuickLook(self.node, clock=lambda: self.now_ns)

    def publisher(self, topic):
        """Return a talker's publisher on ``topic``, once the served node matched it."""
        pub = self.talker.create_publisher(String, topic, 10)
        sub = next(s for s in self.node.subscriptions if s.topic_name == f'/{topic}')
        _wait_for(lambda: sub.get_publisher_count() > 0 and pub.get_subscription_count() > 0)
        return pub

    def census(self):
        """Move the clock past the next census; return what the wake-up then says."""
        self.now_ns = self.look._next_census_ns
        return self.look.anything_ready(0)

    def close(self):
        self.executor.shutdown()
        for node in (self.node, self.talker):
            node.destroy_node()
        for context in self.contexts:
            context.try_shutdown()


def _wait_for(predicate, timeout_s=20.0):
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, 'DDS discovery took too long'
        time.sleep(0.02)


@pytest.fixture(name='served')
def served_fixture():
    served = Served()
    assert served.look.anything_ready(0) is False  # the first wake-up takes a census
    assert served.look.watched == 0
    yield served
    served.close()


def _timed(look, timeout_ns):
    start = time.monotonic_ns()
    return look.anything_ready(timeout_ns), time.monotonic_ns() - start


def test_nothing_ready_waits_its_whole_timeout(served):
    ready, took_ns = _timed(served.look, SHORT_NS)
    assert not ready and took_ns >= SHORT_NS * 0.9


def test_a_topic_with_a_publisher_is_watched_from_the_next_census_on(served):
    pub = served.publisher(TOPICS[0])
    assert served.look.anything_ready(0) is False and served.look.watched == 0  # no census
    assert served.census() is False and served.look.watched == 1
    pub.publish(String(data='a'))
    ready, took_ns = _timed(served.look, LONG_NS)
    assert ready and took_ns < LONG_NS * 0.4
    served.executor.spin_once(timeout_sec=0)
    assert [m.data for m in served.heard] == ['a']
    assert served.look.anything_ready(0) is False


def test_a_census_finds_a_message_whose_publisher_has_gone(served):
    pub = served.publisher(TOPICS[1])
    pub.publish(String(data='b'))
    time.sleep(0.2)  # delivered
    served.talker.destroy_publisher(pub)
    sub = next(s for s in served.node.subscriptions if s.topic_name == f'/{TOPICS[1]}')
    _wait_for(lambda: sub.get_publisher_count() == 0)
    assert served.look.anything_ready(0) is False  # not watched, no census yet
    assert served.census() is True and served.look.watched == 1
    served.executor.spin_once(timeout_sec=0)
    assert [m.data for m in served.heard] == ['b']


def test_every_pending_message_keeps_it_ready_until_taken(served):
    pubs = [served.publisher(topic) for topic in TOPICS]
    served.census()
    for pub, data in zip(pubs, 'ab'):
        pub.publish(String(data=data))
    _wait_for(lambda: served.look.anything_ready(0))
    deadline = time.monotonic() + 5.0
    while len(served.heard) < 2 and time.monotonic() < deadline:
        assert served.look.anything_ready(0)
        served.executor.spin_once(timeout_sec=0)
    assert sorted(m.data for m in served.heard) == ['a', 'b']
    assert served.look.anything_ready(0) is False


def test_a_request_and_a_timer_wake_it(served):
    client = served.talker.create_client(Trigger, 'wakeups_trigger')
    _wait_for(client.service_is_ready)
    client.call_async(Trigger.Request())
    ready, took_ns = _timed(served.look, LONG_NS)
    assert ready and took_ns < LONG_NS * 0.4
    served.executor.spin_once(timeout_sec=0)
    fired = []
    served.node.create_timer(0.3, lambda: fired.append(1))
    served.census()  # a new entity: the look is rebuilt at a census
    ready, took_ns = _timed(served.look, LONG_NS)
    assert ready and 0.2e9 < took_ns < LONG_NS * 0.4, took_ns
    while served.look.anything_ready(0):
        served.executor.spin_once(timeout_sec=0)
    assert fired == [1]


def test_censuses_take_at_most_their_share_of_the_wall_time(served):
    look = served.look
    served.now_ns = look._next_census_ns
    look.anything_ready(0)
    # The clock stood still through it: the next one a period later.
    assert look._next_census_ns == served.now_ns + wakeups.CENSUS_PERIOD_NS
    ticks = iter([served.now_ns + 10**9, served.now_ns + 10**9 + 10**8])  # it took 0.1 s
    look._clock = lambda: next(ticks)
    look._next_census_ns = 0
    look.anything_ready(0)
    assert look._next_census_ns == served.now_ns + 10**9 + int(10**8 / wakeups.CENSUS_SHARE)
