"""Shared pieces of the Python rostests: the newest message of a topic, and a named parameter's value."""
import threading

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
