#!/usr/bin/python3
"""rosbag play --loop: at every loop the clock and the stamps jump back to the bag's start. The node tells it
in its timing diagnostic (WARN, the number of restarts, why the estimates started over), restarts the
identification instead of rejecting the older stamps as out of order, and converges again within the next
loop; its input diagnostics do not stay stale or in error."""
import math
import os
import subprocess
import tempfile
import time
import unittest

import rospy
import yaml
import rostest
from diagnostic_msgs.msg import DiagnosticStatus

from die_cushion_ident.msg import ParameterEstimate
from rostest_helpers import Diagnostics, Latest, tool, value

NS = "/die_cushion/ident/"


class LoopPlay(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_loop_play")
        cls.diagnostics = Diagnostics()
        cls.estimate = Latest(NS + "estimate", ParameterEstimate)
        cls.directory = tempfile.mkdtemp(prefix="loop_play_")
        cls.bag = os.path.join(cls.directory, "press.bag")
        truth = os.path.join(cls.directory, "truth.yaml")
        subprocess.run([tool("simulate_bag"), cls.bag, "--cycles", "6", "--plant-effects", "leakage", "--seed", "5",
                        "--write-truth", truth], check=True, stdout=subprocess.DEVNULL)
        with open(truth) as f:
            cls.truth = yaml.safe_load(f)
        cls.player = subprocess.Popen(["rosbag", "play", "--clock", "--quiet", "--loop", "-r", "2", cls.bag])

    @classmethod
    def tearDownClass(cls):
        cls.player.terminate()
        cls.player.wait()

    def timing(self):
        status = self.diagnostics.get(NS, "input timing")
        return status, ({kv.key: kv.value for kv in status.values} if status else {})

    def test_every_loop_is_told_and_the_identification_converges_again(self):
        # The bag lasts about 16 s, 8 s at twice its speed: wait in wall time for two jumps back.
        deadline = time.time() + 90.0
        while time.time() < deadline:
            status, values = self.timing()
            if status and int(values.get("time base restarts", "0")) >= 2:
                break
            time.sleep(0.5)
        status, values = self.timing()
        self.assertIsNotNone(status, "the timing diagnostic is published")
        self.assertGreaterEqual(int(values["time base restarts"]), 2, status.message)
        self.assertEqual(status.level, DiagnosticStatus.WARN, status.message)
        self.assertIn("jumped back", status.message)
        self.assertIn("started over", status.message)

        # Converged again on the loop after a restart: the leakage plant's parameters within 10 %.
        restarts = int(values["time base restarts"])
        while time.time() < deadline:
            _, values = self.timing()
            if int(values["time base restarts"]) > restarts:
                break
            time.sleep(0.2)
        time.sleep(5.0)  # wall time: 10 s of the bag, about four strokes into the loop
        estimate = self.estimate.get()
        self.assertIsNotNone(estimate)
        for name in ("bulk_modulus", "dead_volume"):
            expected = self.truth[name]
            got = value(estimate, name)
            self.assertTrue(math.isfinite(got), name)
            self.assertLess(abs(got / expected - 1.0), 0.10, "%s %.4g against %.4g" % (name, got, expected))
        pressure = self.diagnostics.get(NS, "input pressure")
        self.assertIsNotNone(pressure)
        self.assertNotEqual(pressure.level, DiagnosticStatus.ERROR, pressure.message)


if __name__ == "__main__":
    rostest.rosrun("die_cushion_ident", "loop_play", LoopPlay)
