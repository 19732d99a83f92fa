"""Shared pieces of the Python rostests: the newest message of a topic, a named parameter's value, and
waiting in simulated time."""
import subprocess
import threading
import time

import rospy


def tool(name):
    """The path of one of the package's command-line tools (simulate_bag, analyze_bag, ...)."""
    found = subprocess.run(["catkin_find", "--first-only", "--libexec", "die_cushion_ident", name],
                           capture_output=True, text=True, check=True)
    return found.stdout.strip()


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


class Diagnostics:
    """Every status on /diagnostics by (name prefix, diagnostic name): the prefix is the identification's own
    name without the leading slash ("die_cushion/ident"), so that a node and a nodelet side by side are told
    apart. Keeps the latest status and, per diagnostic, the (level, message) history."""

    def __init__(self):
        from diagnostic_msgs.msg import DiagnosticArray

        self._lock = threading.Lock()
        self._latest = {}
        self._history = {}
        self._sub = rospy.Subscriber("/diagnostics", DiagnosticArray, self._store)

    def _store(self, msg):
        with self._lock:
            for status in msg.status:
                prefix, _, name = status.name.partition(": ")
                self._latest[(prefix, name)] = status
                self._history.setdefault((prefix, name), []).append((status.level, status.message))

    def get(self, ns, name):
        """The latest status of diagnostic `name` of the identification in namespace `ns` (or None)."""
        with self._lock:
            return self._latest.get((ns.strip("/"), name))

    def history(self, ns, name):
        with self._lock:
            return list(self._history.get((ns.strip("/"), name), []))

    def prefixes(self):
        with self._lock:
            return {prefix for prefix, _ in self._latest}

    def names(self, ns):
        """The names of every status the identification in namespace `ns` has published."""
        with self._lock:
            return {name for prefix, name in self._latest if prefix == ns.strip("/")}


def values_of(status):
    """A status's key/values as a dict."""
    return {kv.key: kv.value for kv in status.values}
