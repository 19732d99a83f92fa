#!/usr/bin/python3
"""~start_step_test live: refused for a step beyond sweep_max_amplitude; run at rest with the command
back at the offset afterwards; while it runs a sweep is refused (one valve experiment at a time) and the
'valve experiments' diagnostic names what holds the valve and why the sweep was refused; the node's t63
(step test diagnostic) within 10 % of the t63 this test computes on its own from the raw pressure
messages."""
import threading
import time
import unittest

import rospy
import rostest
from sensor_msgs.msg import FluidPressure

from die_cushion_ident.msg import ValveSignal
from die_cushion_ident.srv import StartStepTest, StartSweep
from rostest_helpers import Diagnostics, values_of, wait_for, wait_for_clock

NS = "/die_cushion/ident/"


class StepTestLive(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_step_test_live")
        cls.lock = threading.Lock()
        cls.pressure = []  # (stamp, Pa)
        cls.commands = []  # (stamp, V)
        cls.diagnostics = Diagnostics()
        rospy.Subscriber("/die_cushion/pressure", FluidPressure, cls._on_pressure, queue_size=10000)
        rospy.Subscriber("/die_cushion/valve_command", ValveSignal, cls._on_command, queue_size=10000)
        rospy.wait_for_service(NS + "start_step_test", timeout=60)
        cls.start = rospy.ServiceProxy(NS + "start_step_test", StartStepTest)
        cls.sweep = rospy.ServiceProxy(NS + "start_sweep", StartSweep)

    @classmethod
    def _on_pressure(cls, msg):
        with cls.lock:
            cls.pressure.append((msg.header.stamp.to_sec(), msg.fluid_pressure))

    @classmethod
    def _on_command(cls, msg):
        with cls.lock:
            cls.commands.append((msg.header.stamp.to_sec(), msg.voltage))

    def diagnostic(self):
        return self.diagnostics.get(NS, "step test")

    def test_step_test_times_the_pressure(self):
        wait_for_clock()
        time.sleep(3.0)  # the simulated cushion settles at rest
        refused = self.start(offset=0.0, step=-3.0, duration=0.0, settle=0.0)
        self.assertFalse(refused.success)
        self.assertIn("sweep_max_amplitude", refused.message)

        started = self.start(offset=0.0, step=-0.5, duration=1.5, settle=0.3)
        self.assertTrue(started.success, started.message)
        sweep = self.sweep(offset=0.0)
        self.assertFalse(sweep.success, "a sweep while the step test holds the valve")
        self.assertIn("a step test holds the valve", sweep.message)
        wait_for(lambda: (self.diagnostics.get(NS, "valve experiments") is not None and
                          "valve sweep refused" in values_of(self.diagnostics.get(NS, "valve experiments"))
                          .get("last refusal", "")), 10.0, "the refusal in the 'valve experiments' diagnostic")
        wait_for(lambda: self.diagnostic() is not None and "t63" in self.diagnostic().message, 15.0,
                 "the node's t63")
        with self.lock:
            commands = list(self.commands)
            pressure = sorted(self.pressure)
        values = values_of(self.diagnostic())
        self.assertAlmostEqual(commands[-1][1], 0.0, msg="the command is back at the offset")
        step_time = next(t for t, u in commands if abs(u + 0.5) < 1e-9)
        before = [p for t, p in pressure if step_time - 0.1 <= t < step_time]
        during = [(t, p) for t, p in pressure if step_time <= t < step_time + 1.5]
        p0 = sum(before) / len(before)
        tail = during[int(0.8 * len(during)):]
        p1 = sum(p for _, p in tail) / len(tail)
        target = p0 + (1.0 - 0.36787944117144233) * (p1 - p0)
        crossing = next(t for t, p in during if (p - target) * (p1 - p0) >= 0.0)
        expected = crossing - step_time
        t63 = float(values["t63 [s]"])
        rospy.loginfo("live t63 %.1f ms, from the raw pressure %.1f ms", t63 * 1e3, expected * 1e3)
        self.assertAlmostEqual(t63 / expected, 1.0, delta=0.10)


if __name__ == "__main__":
    rostest.rosrun("die_cushion_ident", "step_test_live", StepTestLive)
