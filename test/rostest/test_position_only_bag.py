#!/usr/bin/python3
"""Live on a bag with position only, three joints and a late position clock: the node derives the velocity,
picks the cushion's joint, estimates and corrects the offset, and its comparison and adequacy diagnostic
run (finite modelled pressure, a real error figure) instead of waiting forever."""
import math
import os
import subprocess
import tempfile
import threading
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticStatus

from die_cushion_ident.msg import ModelComparison
from rostest_helpers import Diagnostics, tool

# The node and, beside it on the same played bag, the nodelet (position_only_bag.test starts both).
NAMESPACES = ["/die_cushion/ident/", "/die_cushion/ident_nodelet/"]


class PositionOnlyBag(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_position_only_bag")
        cls.lock = threading.Lock()
        cls.diagnostics = Diagnostics()
        cls.comparisons = {ns: [] for ns in NAMESPACES}
        for ns in NAMESPACES:
            rospy.Subscriber(ns + "model_comparison", ModelComparison, cls._on_comparison, ns)
        cls.directory = tempfile.mkdtemp(prefix="position_only_bag_")
        cls.bag = os.path.join(cls.directory, "press.bag")
        subprocess.run([tool("simulate_bag"), cls.bag, "--cycles", "8", "--plant-effects", "leakage",
                        "--seed", "21", "--no-velocity", "--joints", "ram,cushion,blank_holder",
                        "--stamp-offsets", "0,0.01,0"], check=True)
        cls.player = subprocess.Popen(["rosbag", "play", "--clock", "--quiet", cls.bag])

    @classmethod
    def tearDownClass(cls):
        cls.player.terminate()
        cls.player.wait()

    @classmethod
    def _on_comparison(cls, msg, ns):
        with cls.lock:
            cls.comparisons[ns].append(msg)

    def diagnostic(self, ns, name):
        return self.diagnostics.get(ns, name)

    def test_comparison_and_adequacy_run_on_position_only_data(self):
        # The bag lasts 21 s: wait (in wall time, the bag's clock may not have started) for the end.
        self.player.wait(timeout=120)
        time.sleep(1.0)  # wall time: the bag's clock has stopped
        for ns in NAMESPACES:
            with self.lock:
                comparisons = list(self.comparisons[ns])
            self.assertGreater(len(comparisons), 100, ns)
            finite = [c for c in comparisons if math.isfinite(c.modelled_pressure) and math.isfinite(c.velocity)]
            self.assertGreater(len(finite), 0.5 * len(comparisons),
                               "the velocity is derived from the position and the model runs")
            moving = [c for c in finite if abs(c.velocity) > 0.1]
            self.assertTrue(moving, "the derived velocity shows the strokes")
            last = comparisons[-1]
            self.assertTrue(math.isfinite(last.simulation_error_rms))
            self.assertLess(last.simulation_error_rms, 3e5, "the right model follows the pressure within 3 bar")

            adequacy = self.diagnostic(ns, "model adequacy")
            self.assertIsNotNone(adequacy)
            self.assertNotIn("not enough data", adequacy.message)
            self.assertIn("the model follows the pressure", adequacy.message)
            timing = self.diagnostic(ns, "input timing")
            self.assertIsNotNone(timing)
            values = {kv.key: kv.value for kv in timing.values}
            self.assertAlmostEqual(float(values["delay of position stamps [ms]"]), 10.0, delta=1.0,
                                   msg=timing.message)
            self.assertEqual(timing.level, DiagnosticStatus.WARN, "a 10 ms offset is worth a warning")
            position = self.diagnostic(ns, "input position")
            self.assertEqual(position.level, DiagnosticStatus.OK, position.message)


if __name__ == "__main__":
    rostest.rosrun("die_cushion_ident", "position_only_bag", PositionOnlyBag)
