"""Shared pieces of the Python rostests: the newest message of a topic, a named parameter's value, and
waiting in simulated time."""
import threading
import time

import rospy


class Latest:
    """The newest message of a topic (thread-safe)."""

    def __init__(self, topic, msg_type):
        self._lock = threading.Lock()
        self._msg = None
        self._sub = rospy.Subscriber(topic, msg_type, self._store)

    def _store(self, msg):
        with self._lock:
            self._msg = msg

    def get(self):
        with self._lock:
            return self._msg


def value(msg, name):
    """A parameter's value from a ParameterEstimate, by name."""
    return msg.values[list(msg.names).index(name)]


def wait_for_clock(wall_timeout=60.0):
    """Under /use_sim_time the clock reads 0 until the first /clock message: a deadline taken then is already
    past once the simulation's clock (1000 s and more) arrives. Wait for it in wall time."""
    deadline = time.time() + wall_timeout
    while not rospy.is_shutdown() and rospy.Time.now().is_zero() and time.time() < deadline:
        time.sleep(0.05)


def wait_for(predicate, timeout, what):
    """Until predicate() holds, at most `timeout` seconds of (simulated) ROS time."""
    wait_for_clock()
    deadline = rospy.Time.now() + rospy.Duration(timeout)
    while not rospy.is_shutdown() and rospy.Time.now() < deadline:
        if predicate():
            return
        rospy.sleep(0.2)
    raise AssertionError("timed out (%.0f s sim time) waiting for %s" % (timeout, what))
