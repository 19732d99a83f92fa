#!/usr/bin/python3
"""The node's live feed-forward against the simulator on sim time: once the model is identified, a
pressure_setpoint stream gives ~feed_forward commands, finite and inside the requested +-4 V; NaN
set-points are refused and counted; when the set-point falls silent the command is withdrawn (0 V) and the
feed-forward diagnostic says it is stale."""
import math
import threading
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import FluidPressure

from die_cushion_ident.msg import ParameterEstimate, ValveSignal
from rostest_helpers import Diagnostics, Latest, wait_for, wait_for_clock

# The node and, beside it on the same inputs and set-point, the nodelet (feed_forward_live.test starts both).
NAMESPACES = ["/die_cushion/ident/", "/die_cushion/ident_nodelet/"]


class FeedForwardLive(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_feed_forward_live")
        cls.lock = threading.Lock()
        cls.commands = {ns: [] for ns in NAMESPACES}
        cls.diagnostics = Diagnostics()
        cls.estimates = {}
        for ns in NAMESPACES:
            rospy.Subscriber(ns + "feed_forward", ValveSignal, cls._on_command, ns)
            cls.estimates[ns] = Latest(ns + "estimate", ParameterEstimate)
        cls.setpoint = rospy.Publisher("/die_cushion/pressure_setpoint", FluidPressure, queue_size=100)
        cls.value = 100e5  # what the stream sends; None: silent

    @classmethod
    def _on_command(cls, msg, ns):
        with cls.lock:
            cls.commands[ns].append(msg.voltage)

    def diagnostic(self, ns):
        return self.diagnostics.get(ns, "feed-forward")

    def stream(self, stop):
        while not stop.is_set() and not rospy.is_shutdown():
            if self.value is not None:
                self.setpoint.publish(FluidPressure(header=rospy.Header(stamp=rospy.Time.now()),
                                                    fluid_pressure=self.value))
            time.sleep(0.005)

    def test_commands_inside_the_range_nan_refused_silence_withdraws(self):
        wait_for_clock()
        wait_for(lambda: all(e.get() is not None and e.get().updates > 300 for e in self.estimates.values()), 60.0,
                 "the estimators to identify the model")
        stop = threading.Event()
        threading.Thread(target=self.stream, args=(stop,), daemon=True).start()
        try:
            wait_for(lambda: all(len(c) > 200 for c in self.commands.values()), 20.0, "feed-forward commands")
            for ns in NAMESPACES:
                with self.lock:
                    commands = list(self.commands[ns])
                self.assertTrue(all(math.isfinite(u) and abs(u) <= 4.0 + 1e-9 for u in commands), ns + str(commands[:20]))
                self.assertTrue(any(abs(u) > 1e-6 for u in commands), ns + ": some command is not zero")

            self.value = float("nan")  # a broken set-point: refused, then the good one is stale
            for ns in NAMESPACES:
                wait_for(lambda: self.diagnostic(ns) is not None and self.diagnostic(ns).level == DiagnosticStatus.WARN
                         and "stale" in self.diagnostic(ns).message, 10.0, ns + ": a WARN that the set-point is stale")
                refused = {v.key: v.value for v in self.diagnostic(ns).values}[
                    "set-points refused (NaN or stamp not advancing)"]
                self.assertGreater(int(refused), 0, ns)
                with self.lock:
                    self.assertEqual(self.commands[ns][-1], 0.0, ns + ": the command is withdrawn")
                    self.assertTrue(all(math.isfinite(u) and abs(u) <= 4.0 + 1e-9 for u in self.commands[ns]))
        finally:
            stop.set()

if __name__ == "__main__":
    rostest.rosrun("die_cushion_ident", "feed_forward_live", FeedForwardLive)
