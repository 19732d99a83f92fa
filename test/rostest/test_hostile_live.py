#!/usr/bin/python3
"""The hostile-input review's live cases, each reproduced against a running press (the simulator):
20 pressure messages of 1e300 Pa left every std NaN for good; one wild stamp per second kept restarting the
identification; a position clock 1000 s ahead for 5 s stopped the estimates and blamed the healthy topics;
set_effects accepted a term worth 1e300. Now each is rejected and named, and the estimates stay right."""
import math
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticStatus
from sensor_msgs.msg import FluidPressure, JointState

from die_cushion_ident.msg import ModelComparison, ParameterEstimate, ValveSignal
from die_cushion_ident.srv import SetEffects
from rostest_helpers import Diagnostics, Latest, value, wait_for_clock

# The node and, beside it on the same (hostile) inputs, the nodelet (hostile_live.test starts both).
NAMESPACES = ["/die_cushion/ident/", "/die_cushion/ident_nodelet/"]


class HostileLive(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_hostile_live")
        cls.estimate = {ns: Latest(ns + "estimate", ParameterEstimate) for ns in NAMESPACES}
        cls.comparison = {ns: Latest(ns + "model_comparison", ModelComparison) for ns in NAMESPACES}
        cls.truth = Latest("/die_cushion/simulator/truth", ParameterEstimate)
        cls.diagnostics = Diagnostics()
        cls.pressure = rospy.Publisher("/die_cushion/pressure", FluidPressure, queue_size=10000)
        cls.position = rospy.Publisher("/die_cushion/position", JointState, queue_size=10000)
        cls.valve = rospy.Publisher("/die_cushion/valve", ValveSignal, queue_size=10000)
        cls.set_effects = {}
        for ns in NAMESPACES:
            rospy.wait_for_service(ns + "set_effects", timeout=60)
            cls.set_effects[ns] = rospy.ServiceProxy(ns + "set_effects", SetEffects)

    def wait_sim(self, seconds):
        wait_for_clock()
        end = rospy.Time.now() + rospy.Duration(seconds)
        while not rospy.is_shutdown() and rospy.Time.now() < end:
            time.sleep(0.05)

    def expect_right(self, what):
        """Every target's estimates right and finite; returns them by namespace."""
        return {ns: self.expect_right_in(ns, ns + " " + what) for ns in NAMESPACES}

    def expect_right_in(self, ns, what):
        estimate, truth = self.estimate[ns].get(), self.truth.get()
        self.assertIsNotNone(estimate, what)
        for name, bound in [("bulk_modulus", 0.05), ("valve_flow_gain", 0.02)]:
            self.assertTrue(math.isfinite(value(estimate, name)), "%s: %s" % (what, name))
            error = value(estimate, name) / value(truth, name) - 1.0
            self.assertLess(abs(error), bound, "%s: %s off by %.1f %%" % (what, name, 100 * error))
        for std in estimate.standard_deviations:
            self.assertTrue(math.isfinite(std), what)
        self.assertTrue(math.isfinite(estimate.equation_error_rms), what)
        comparison = self.comparison[ns].get()
        self.assertTrue(math.isfinite(comparison.simulation_error_rms), what)
        return estimate

    def test_hostile_cases_are_rejected_named_and_recovered_from(self):
        deadline = time.time() + 60
        while time.time() < deadline and (any(e.get() is None for e in self.estimate.values())
                                          or self.truth.get() is None):
            time.sleep(0.2)
        self.wait_sim(8.0)  # three strokes
        before = self.expect_right("before")

        # 1. Twenty pressure messages of 1e300 Pa.
        now = rospy.Time.now()
        for k in range(20):
            self.pressure.publish(FluidPressure(header=rospy.Header(stamp=now + rospy.Duration(0.0002 * k)),
                                                fluid_pressure=1e300))
        self.wait_sim(3.0)  # one press cycle
        self.expect_right("after 20 pressures of 1e300 Pa")

        # 2. One wild stamp per second: 100 s in the past, 1000 s ahead.
        for k in range(4):
            now = rospy.Time.now()
            self.pressure.publish(FluidPressure(header=rospy.Header(stamp=now - rospy.Duration(100.0)),
                                                fluid_pressure=50e5))
            self.valve.publish(ValveSignal(header=rospy.Header(stamp=now + rospy.Duration(1000.0)), voltage=0.0,
                                           spool_position=0.0))
            self.wait_sim(1.0)
        after_wild = self.expect_right("after single wild stamps")
        for ns in NAMESPACES:
            self.assertGreater(after_wild[ns].updates, before[ns].updates, ns + ": the identification was not restarted")

        # 3. The position clock 1000 s ahead for 5 s (the simulator's own position messages go on too).
        end = rospy.Time.now() + rospy.Duration(5.0)
        while rospy.Time.now() < end:
            stamp = rospy.Time.now() + rospy.Duration(1000.0)
            self.position.publish(JointState(header=rospy.Header(stamp=stamp), name=["cushion"], position=[0.0],
                                             velocity=[0.0]))
            time.sleep(0.002)
        self.wait_sim(3.0)
        after_clock = self.expect_right("after a position clock 1000 s ahead")
        for ns in NAMESPACES:
            self.assertGreater(after_clock[ns].updates, after_wild[ns].updates, ns + ": not restarted, not stopped")
            position = self.diagnostics.history(ns, "input position")
            pressure = self.diagnostics.history(ns, "input pressure")
            self.assertTrue(any(level == DiagnosticStatus.ERROR and "clock jumped" in message
                                for level, message in position), ns + ": the position topic is named")
            self.assertFalse(any("stale" in message for _, message in pressure),
                             ns + ": the healthy topics are not blamed")

        # 4. A custom term worth 1e300 is refused with the reason; the model stays as it was.
        for ns in NAMESPACES:
            response = self.set_effects[ns](effects=["leakage"], custom_effects=["x=(p>100e5)?1e300:0"])
            self.assertFalse(response.success, ns)
            self.assertIn("1e+300", response.message)
        self.wait_sim(1.0)
        self.expect_right("after the refused custom term")


if __name__ == "__main__":
    rostest.rosrun("die_cushion_ident", "hostile_live", HostileLive)
