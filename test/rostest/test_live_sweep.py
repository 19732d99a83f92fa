#!/usr/bin/python3
"""A sweep started through the service identifies the simulated valve; the valve command follows the sweep
and returns to the offset; an aborted sweep says so; a second request while running is refused."""
import subprocess
import threading
import unittest

import rospy
import rostest

from die_cushion_ident.msg import FrequencyResponse, ValveModel, ValveSignal
from die_cushion_ident.srv import AbortSweep, StartSweep
from rostest_helpers import wait_for_clock

NS = "/die_cushion/ident/"


class LiveSweep(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_live_sweep")
        cls.lock = threading.Lock()
        cls.models, cls.commands, cls.responses = [], [], []
        cls.truth = None
        rospy.Subscriber(NS + "valve_model", ValveModel, lambda m: cls._append(cls.models, m))
        rospy.Subscriber(NS + "frequency_response", FrequencyResponse, lambda m: cls._append(cls.responses, m))
        rospy.Subscriber("/die_cushion/valve_command", ValveSignal, lambda m: cls._append(cls.commands, m))
        rospy.Subscriber("/die_cushion/simulator/valve_truth", ValveModel, cls._on_truth)
        rospy.wait_for_service(NS + "start_sweep", timeout=60)
        cls.start = rospy.ServiceProxy(NS + "start_sweep", StartSweep)
        cls.abort = rospy.ServiceProxy(NS + "abort_sweep", AbortSweep)

    @classmethod
    def _append(cls, items, msg):
        with cls.lock:
            items.append(msg)

    @classmethod
    def _on_truth(cls, msg):
        cls.truth = msg

    def wait_for_model(self, count, timeout):
        wait_for_clock()
        deadline = rospy.Time.now() + rospy.Duration(timeout)
        while rospy.Time.now() < deadline and not rospy.is_shutdown():
            with self.lock:
                if len(self.models) >= count:
                    return self.models[count - 1]
            rospy.sleep(0.2)
        self.fail("no valve model after %.0f s" % timeout)

    def request(self, **fields):
        base = dict(frequencies=[], amplitude=0.0, offset=0.0, settle_periods=0.0, integration_periods=0.0)
        base.update(fields)
        return self.start(**base)

    def test_1_sweep_identifies_the_valve(self):
        rospy.sleep(1.0)  # let the plant condition settle
        started = self.request(offset=0.1)
        self.assertTrue(started.success, started.message)
        self.assertGreater(started.expected_duration, 5.0)
        again = self.request()
        self.assertFalse(again.success)
        self.assertIn("a valve sweep holds the valve", again.message)  # one experiment at a time
        model = self.wait_for_model(1, started.expected_duration + 20.0)
        self.assertTrue(model.success, model.message)
        truth = self.truth
        self.assertIsNotNone(truth)
        self.assertLess(abs(model.natural_frequency / truth.natural_frequency - 1), 0.03)
        self.assertLess(abs(model.damping / truth.damping - 1), 0.10)
        self.assertLess(abs(model.gain / truth.gain - 1), 0.02)
        self.assertLess(abs(model.dead_time - truth.dead_time), 0.3e-3)
        rospy.sleep(0.5)
        with self.lock:
            voltages = [c.voltage for c in self.commands]
            response = self.responses[-1]
        self.assertGreater(len(voltages), 1000)
        self.assertAlmostEqual(voltages[-1], 0.1)  # back at the offset
        self.assertLessEqual(max(voltages), 0.6 + 1e-9)
        self.assertGreaterEqual(min(voltages), -0.4 - 1e-9)
        self.assertEqual(response.state, "finished")
        self.assertEqual(len(response.frequency), 16)
        self.assertEqual(len(response.fit_frequency), 101)

    def test_2_abort_returns_the_valve_and_reports(self):
        started = self.request(frequencies=[20.0, 40.0, 60.0, 80.0, 100.0], offset=0.2)
        self.assertTrue(started.success, started.message)
        rospy.sleep(0.3)
        aborted = self.abort()
        self.assertTrue(aborted.success, aborted.message)
        model = self.wait_for_model(2, 10.0)
        self.assertFalse(model.success)
        self.assertIn("aborted by request", model.message)
        rospy.sleep(0.3)
        with self.lock:
            self.assertAlmostEqual(self.commands[-1].voltage, 0.2)
        self.assertFalse(self.abort().success)  # nothing left to abort
        outside = self.request(offset=1.8)  # 1.8 + 0.5 V exceeds sweep_max_voltage = 2 V
        self.assertFalse(outside.success)
        self.assertIn("command range", outside.message)

    def test_3_invalid_parameters_are_refused_at_start_up(self):
        # The workspace's own binary (rosrun would also see copies in other build directories of the checkout).
        node = subprocess.run(["catkin_find", "--first-only", "--libexec", "die_cushion_ident", "identification_node"],
                              capture_output=True, text=True, check=True).stdout.strip()
        result = subprocess.run(
            [node, "__name:=bad_ident", "_forgetting_factor:=2.0",
             "_moving_average_width:=30", "_effects:=[leakage, no_such_effect]", "_sweep_max_amplitude:=-1"],
            capture_output=True, text=True, timeout=60)
        self.assertEqual(result.returncode, 2, result.stdout + result.stderr)
        output = result.stdout + result.stderr
        for expected in ["~forgetting_factor = 2 is invalid", "~moving_average_width = 30 is invalid",
                         "no_such_effect", "~sweep_max_amplitude = -1 is invalid: allowed > 0 V"]:
            self.assertIn(expected, output)


if __name__ == "__main__":
    rostest.rosrun("die_cushion_ident", "live_sweep", LiveSweep)
