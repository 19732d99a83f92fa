#!/usr/bin/python3
"""Hostile inputs for the node: NaN/Inf values, zero, duplicate, out-of-order and jumping stamps, empty
JointState arrays, bursts; service requests with non-finite, negative, huge and above-Nyquist values and
unknown effects. The node stays up, every refusal has a reason, the diagnostics count the rejections."""
import math
import unittest

import rospy
import rostest
from sensor_msgs.msg import FluidPressure, JointState

from die_cushion_ident.msg import ValveSignal
from die_cushion_ident.srv import AbortSweep, Reset, SetEffects, StartSweep
from rostest_helpers import Diagnostics, values_of

# The node and, beside it on the same topics, the nodelet in a manager (hostile_inputs.test starts both).
NAMESPACES = ["/die_cushion/ident/", "/die_cushion/ident_nodelet/"]


class HostileInputs(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_hostile_inputs")
        cls.diagnostics = Diagnostics()
        cls.pressure = rospy.Publisher("/die_cushion/pressure", FluidPressure, queue_size=1000)
        cls.position = rospy.Publisher("/die_cushion/position", JointState, queue_size=1000)
        cls.valve = rospy.Publisher("/die_cushion/valve", ValveSignal, queue_size=1000)
        for ns in NAMESPACES:
            rospy.wait_for_service(ns + "start_sweep", timeout=30)
        rospy.sleep(1.0)  # connections

    def send(self, t, p=1e6, x=0.01, v=0.0, u=0.0, y=0.0, empty_position=False):
        stamp = rospy.Time(t) if t >= 0 and math.isfinite(t) else rospy.Time(0)
        self.pressure.publish(FluidPressure(header=rospy.Header(stamp=stamp), fluid_pressure=p))
        joint = JointState(header=rospy.Header(stamp=stamp))
        if not empty_position:
            joint.position, joint.velocity = [x], [v]
        self.position.publish(joint)
        self.valve.publish(ValveSignal(header=rospy.Header(stamp=stamp), voltage=u, spool_position=y))

    def test_1_hostile_messages(self):
        t = 1000.0
        for i in range(3000):
            t += 0.001
            kind = i % 11
            if kind == 0:
                self.send(t, p=float("nan"))
            elif kind == 1:
                self.send(t, p=float("inf"), u=float("-inf"))
            elif kind == 2:
                self.send(0.0)  # stamp zero
            elif kind == 3:
                self.send(t - 0.5)  # out of order
            elif kind == 4:
                self.send(t, empty_position=True)
            elif kind == 5:
                self.send(t, y=float("nan"), x=float("nan"))
            elif kind == 6:
                self.send(t, p=1e300, x=1e300, v=-1e300, u=1e300, y=5.0)  # saturated far beyond physics
            elif kind == 7 and i % 500 == 7:
                t += 30.0  # a jump forward
            else:
                self.send(t, p=50e5 + 1e5 * math.sin(t), x=0.01, v=0.0)
            if i % 100 == 0:
                rospy.sleep(0.01)
        # The rejections show in the next diagnostics (1 Hz); on a loaded machine that may take a few.
        inputs = [(ns, n) for ns in NAMESPACES for n in ["input pressure", "input position", "input valve"]]

        def rejected(ns, name):
            status = self.diagnostics.get(ns, name)
            return status is not None and int(values_of(status)["rejected"]) > 0

        deadline = rospy.Time.now() + rospy.Duration(10.0)
        while rospy.Time.now() < deadline and not all(rejected(ns, name) for ns, name in inputs):
            rospy.sleep(0.5)
        for ns, name in inputs:
            status = self.diagnostics.get(ns, name)
            self.assertIsNotNone(status, ns + name)
            values = values_of(status)
            self.assertGreater(int(values["rejected"]), 0, ns + name)
            self.assertNotEqual(values["last rejection"], "none", ns + name)
        for ns in NAMESPACES:
            estimator = values_of(self.diagnostics.get(ns, "estimator"))
            for key, value in estimator.items():
                if key.endswith("]"):
                    self.assertNotIn("nan", value.lower(), ns + key)
                    self.assertNotIn("inf", value.lower(), ns + key)

    def test_2_hostile_service_requests(self):
        for ns in NAMESPACES:
            self.hostile_service_requests(ns)

    def hostile_service_requests(self, ns):
        start = rospy.ServiceProxy(ns + "start_sweep", StartSweep)
        abort = rospy.ServiceProxy(ns + "abort_sweep", AbortSweep)
        set_effects = rospy.ServiceProxy(ns + "set_effects", SetEffects)
        reset = rospy.ServiceProxy(ns + "reset", Reset)
        nan, inf = float("nan"), float("inf")
        cases = [
            dict(frequencies=[nan], amplitude=0.5),
            dict(frequencies=[-10.0], amplitude=0.5),
            dict(frequencies=[0.0], amplitude=0.5),
            dict(frequencies=[1e9], amplitude=0.5),
            dict(frequencies=[20.0], amplitude=nan),
            dict(frequencies=[20.0], amplitude=-1.0),
            dict(frequencies=[20.0], amplitude=inf),
            dict(frequencies=[20.0], amplitude=0.5, offset=nan),
            dict(frequencies=[20.0], amplitude=0.5, offset=1e9),
            dict(frequencies=[20.0], amplitude=0.5, integration_periods=1e12),
            dict(frequencies=[20.0], amplitude=0.5, settle_periods=-3.0),
            dict(frequencies=[20.0] * 5000, amplitude=0.5),
        ]
        for fields in cases:
            request = dict(frequencies=[], amplitude=0.0, offset=0.0, settle_periods=0.0, integration_periods=0.0)
            request.update(fields)
            response = start(**request)
            self.assertFalse(response.success, str(fields)[:80])
            self.assertTrue(response.message.startswith("sweep refused: ") and len(response.message) > 20,
                            response.message)
        self.assertFalse(abort().success)
        for effects, custom in [(["leakage", ""], []), (["x" * 10000], []), (["leakage"], ["=p"]), ([], ["a=p*("]),
                                ([], ["b=sqrt(p"]), ([], ["c=unknown_signal*2"]), (["leakage", "leakage"], [])]:
            response = set_effects(effects=effects, custom_effects=custom)
            if response.success:  # a duplicate may be accepted, but then it is one effect
                self.assertEqual(len(response.parameters), len(set(response.parameters)))
            else:
                self.assertTrue(response.message.startswith("effects refused: "), response.message)
        self.assertTrue(reset().success)
        # Still alive and answering.
        rospy.wait_for_service(ns + "start_sweep", timeout=5)


if __name__ == "__main__":
    rostest.rosrun("die_cushion_ident", "hostile_inputs", HostileInputs)
