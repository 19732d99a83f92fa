#!/usr/bin/python3
"""Live identification on ROS: estimates converge to the simulator's truth, diagnostics report the right
levels, set_effects changes the model, unsafe and invalid sweep requests are refused."""
import threading
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

from die_cushion_ident.msg import EffectRanking, ModelComparison, ParameterEstimate
from die_cushion_ident.srv import SetEffects, StartSweep
from rostest_helpers import Latest, value, wait_for

NS = "/die_cushion/ident/"


class LiveIdentification(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_live_identification")
        cls.estimate = Latest(NS + "estimate", ParameterEstimate)
        cls.comparison = Latest(NS + "model_comparison", ModelComparison)
        cls.truth = Latest("/die_cushion/simulator/truth", ParameterEstimate)
        cls.ranking = Latest(NS + "effect_ranking", EffectRanking)
        cls.diagnostics = {}
        cls.prefixes = set()
        cls.lock = threading.Lock()
        rospy.Subscriber("/diagnostics", DiagnosticArray, cls._on_diagnostics)
        rospy.wait_for_service(NS + "set_effects", timeout=60)
        cls.set_effects = rospy.ServiceProxy(NS + "set_effects", SetEffects)
        cls.start_sweep = rospy.ServiceProxy(NS + "start_sweep", StartSweep)

    @classmethod
    def _on_diagnostics(cls, msg):
        with cls.lock:
            for status in msg.status:
                cls.diagnostics[status.name.split(": ", 1)[-1]] = status
                cls.prefixes.add(status.name.split(": ", 1)[0])

    def diagnostic(self, name):
        with self.lock:
            return self.diagnostics.get(name)

    def test_1_estimates_converge_to_truth_and_diagnostics_are_ok(self):
        wait_for(lambda: self.truth.get() is not None and self.estimate.get() is not None, 30, "estimates")
        rospy.sleep(16.0)  # six press cycles
        estimate, truth = self.estimate.get(), self.truth.get()
        self.assertEqual(list(estimate.effects), ["leakage"])
        for name, bound in [("bulk_modulus", 0.05), ("valve_flow_gain", 0.02), ("leakage_conductance", 0.2)]:
            error = value(estimate, name) / value(truth, name) - 1.0
            self.assertLess(abs(error), bound, "%s off by %.1f %%" % (name, 100 * error))
        self.assertAlmostEqual(estimate.bulk_modulus, value(estimate, "bulk_modulus"))
        wait_for(lambda: self.diagnostic("estimator") is not None, 10, "diagnostics")
        for name in ["input pressure", "input position", "input valve", "estimator", "model adequacy"]:
            status = self.diagnostic(name)
            self.assertEqual(status.level, DiagnosticStatus.OK, "%s: %s" % (name, status.message))
        comparison = self.comparison.get()
        self.assertLess(comparison.simulation_error_rms, 3e5)
        # The nodelet's diagnostics carry its own name, not the manager's (two nodelets must not collide).
        with self.lock:
            prefixes = set(self.prefixes)
        self.assertIn("die_cushion/ident", prefixes)  # diagnostic_updater drops the leading slash
        self.assertNotIn("die_cushion/manager", prefixes)

    def test_2_unsafe_and_invalid_sweeps_are_refused(self):
        wait_for(lambda: self.comparison.get() is not None and self.comparison.get().phase == 2, 10, "drawing")
        refused = self.start_sweep(frequencies=[], amplitude=0.0, offset=0.0, settle_periods=0.0,
                                   integration_periods=0.0)
        self.assertFalse(refused.success)
        self.assertIn("refused", refused.message)
        too_big = self.start_sweep(frequencies=[20.0], amplitude=5.0, offset=0.0, settle_periods=0.0,
                                   integration_periods=0.0)
        self.assertFalse(too_big.success)
        self.assertIn("sweep_max_amplitude", too_big.message)
        nyquist = self.start_sweep(frequencies=[900.0], amplitude=0.5, offset=0.0, settle_periods=0.0,
                                   integration_periods=0.0)
        self.assertFalse(nyquist.success)
        self.assertIn("Nyquist", nyquist.message)

    def test_3_set_effects_changes_the_model_and_the_error_shows_it(self):
        with_leakage = self.comparison.get().simulation_error_rms
        bad = self.set_effects(effects=["no_such_effect"], custom_effects=[])
        self.assertFalse(bad.success)
        self.assertIn("no_such_effect", bad.message)
        base = self.set_effects(effects=[], custom_effects=[])
        self.assertTrue(base.success, base.message)
        self.assertEqual(list(base.parameters), ["bulk_modulus", "valve_flow_gain", "dead_volume"])
        wait_for(lambda: list(self.estimate.get().effects) == [], 5, "the base model's estimates")
        rospy.sleep(12.0)
        without_leakage = self.comparison.get().simulation_error_rms
        ranking = self.ranking.get()
        self.assertEqual(ranking.effects[0], "leakage", ranking.conclusion)
        self.assertEqual(ranking.verdicts[0], "missing", ranking.explanations[0])
        self.assertNotIn("missing", ranking.verdicts[1:])
        rospy.sleep(1.5)  # the next diagnostics include the ranking
        adequacy = self.diagnostic("model adequacy")
        self.assertIn(adequacy.level, (DiagnosticStatus.WARN, DiagnosticStatus.ERROR), adequacy.message)
        self.assertIn("misses the pressure", adequacy.message)
        self.assertIn("suspected missing effect: leakage", adequacy.message)
        self.assertGreater(without_leakage, 2.0 * with_leakage,
                           "leaving out the plant's leakage must show in the error (%.2f vs %.2f bar)"
                           % (without_leakage * 1e-5, with_leakage * 1e-5))
        broken = self.set_effects(effects=["leakage"], custom_effects=["broken=p*("])
        self.assertFalse(broken.success)
        self.assertIn("broken", broken.message)
        custom = self.set_effects(effects=["leakage"], custom_effects=["bypass=p"])
        self.assertTrue(custom.success, custom.message)
        self.assertIn("bypass_theta", list(custom.parameters))


if __name__ == "__main__":
    rostest.rosrun("die_cushion_ident", "live_identification", LiveIdentification)
