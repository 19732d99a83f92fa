#!/usr/bin/python3
"""Live identification on ROS: estimates converge to the simulator's truth, diagnostics report the right
levels and the aggregator groups them (params/diagnostics.yaml), a live threshold changed with
dynamic_reconfigure takes effect at once, set_effects changes the model, unsafe and invalid sweep requests are
refused."""
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from dynamic_reconfigure.client import Client

from die_cushion_ident.msg import EffectRanking, ModelComparison, ParameterEstimate
from die_cushion_ident.srv import SetEffects, StartSweep
from rostest_helpers import Diagnostics, Latest, value, wait_for

# The same checks on the identification as a nodelet in a manager and as its own node, side by side on
# one simulator (live_identification.test starts both).
NAMESPACES = ["/die_cushion/ident/", "/die_cushion/ident_node/"]


class Target:
    """One identification under test: its outputs, services and diagnostics (by its name's prefix)."""

    def __init__(self, ns):
        self.ns = ns
        self.estimate = Latest(ns + "estimate", ParameterEstimate)
        self.comparison = Latest(ns + "model_comparison", ModelComparison)
        self.ranking = Latest(ns + "effect_ranking", EffectRanking)
        rospy.wait_for_service(ns + "set_effects", timeout=60)
        self.set_effects = rospy.ServiceProxy(ns + "set_effects", SetEffects)
        self.start_sweep = rospy.ServiceProxy(ns + "start_sweep", StartSweep)


class LiveIdentification(unittest.TestCase):
    @classmethod
    def setUpClass(cls):
        rospy.init_node("test_live_identification")
        cls.truth = Latest("/die_cushion/simulator/truth", ParameterEstimate)
        cls.diagnostics = Diagnostics()
        cls.aggregated = Latest("/diagnostics_agg", DiagnosticArray)
        cls.targets = [Target(ns) for ns in NAMESPACES]

    def diagnostic(self, target, name):
        return self.diagnostics.get(target.ns, name)

    def test_1_estimates_converge_to_truth_and_diagnostics_are_ok(self):
        wait_for(lambda: self.truth.get() is not None and all(t.estimate.get() is not None for t in self.targets),
                 30, "estimates")
        # The node chooses its settings from its first 8 s (the paper's press: the paper's grid, nothing
        # restarted); the nodelet, with the default 24 s, is still surveying then. Checked when the node has
        # chosen, not after a fixed sleep: on a loaded machine the test's wait ran past the nodelet's 24 s.
        # The nodelet's own settings status too: under load this test can start after the node has chosen, and
        # before the nodelet's first diagnostics have reached it.
        wait_for(lambda: "chosen from the recording" in
                 getattr(self.diagnostic(self.targets[1], "settings"), "message", "") and
                 self.diagnostic(self.targets[0], "settings") is not None, 30, "the node's and the nodelet's settings")
        self.assertIn("surveying", self.diagnostic(self.targets[0], "settings").message)
        rospy.sleep(16.0)  # six press cycles
        for target in self.targets:
            estimate, truth = target.estimate.get(), self.truth.get()
            self.assertEqual(list(estimate.effects), ["leakage"])
            for name, bound in [("bulk_modulus", 0.05), ("valve_flow_gain", 0.02), ("leakage_conductance", 0.2)]:
                error = value(estimate, name) / value(truth, name) - 1.0
                self.assertLess(abs(error), bound, "%s%s off by %.1f %%" % (target.ns, name, 100 * error))
            self.assertAlmostEqual(estimate.bulk_modulus, value(estimate, "bulk_modulus"))
            wait_for(lambda: self.diagnostic(target, "estimator") is not None, 10, "diagnostics")
            for name in ["input pressure", "input position", "input valve", "estimator", "model adequacy"]:
                status = self.diagnostic(target, name)
                self.assertEqual(status.level, DiagnosticStatus.OK, "%s %s: %s" % (target.ns, name, status.message))
            self.assertLess(target.comparison.get().simulation_error_rms, 3e5)
        chosen = self.diagnostic(self.targets[1], "settings")
        self.assertIn("chosen from the recording: sample_period 2 ms", chosen.message)
        self.assertEqual(chosen.level, DiagnosticStatus.OK, chosen.message)
        reasons = {kv.key: kv.value for kv in chosen.values}
        self.assertIn("why sample_period", reasons)
        self.assertIn("resolution error [bar]", reasons)
        # Each identification's diagnostics carry its own name; the nodelet's not the manager's (two nodelets
        # in one manager must not collide).
        prefixes = self.diagnostics.prefixes()
        self.assertIn("die_cushion/ident", prefixes)
        self.assertIn("die_cushion/ident_node", prefixes)
        self.assertNotIn("die_cushion/manager", prefixes)

    # Where params/diagnostics.yaml puts each status of the identification (doc/ros_interface.md, "Diagnostics").
    ANALYZERS = {"input pressure": "Inputs", "input position": "Inputs", "input valve": "Inputs",
                 "input timing": "Inputs", "input oil_temperature": "Inputs", "estimator": "Estimation", "settings": "Estimation",
                 "model adequacy": "Model adequacy", "valve model": "Valve experiments",
                 "step test": "Valve experiments", "valve experiments": "Valve experiments",
                 "feed-forward": "Feed-forward"}

    def test_1a_the_aggregator_groups_every_status_under_its_analyzer(self):
        def aggregated_names():
            msg = self.aggregated.get()
            return {status.name for status in msg.status} if msg else set()

        for target in self.targets:
            # Every status the identification publishes is one the yaml groups (a new one fails here first).
            wait_for(lambda: set(self.ANALYZERS) <= self.diagnostics.names(target.ns), 10, target.ns + " statuses")
            self.assertEqual(self.diagnostics.names(target.ns), set(self.ANALYZERS), target.ns)
            # The aggregator writes a status "<path>/<status name, slashes as spaces>".
            shown = target.ns.strip("/").replace("/", " ")
            for name, analyzer in self.ANALYZERS.items():
                path = "/Die cushion/%s/%s: %s" % (analyzer, shown, name)
                wait_for(lambda: path in aggregated_names(), 10, path)
            strays = [n for n in aggregated_names() if shown + ":" in n and not n.startswith("/Die cushion/")]
            self.assertEqual(strays, [], "statuses left outside the analyzers (in Other)")

    def test_1b_a_live_threshold_changed_with_dynamic_reconfigure_takes_effect_at_once(self):
        for target in self.targets:
            client = Client(target.ns.rstrip("/"), timeout=10)
            live = {d["name"] for d in client.get_parameter_descriptions()}
            self.assertEqual(live, {"adequacy_warn_error", "adequacy_error_error", "effect_ranking_window",
                                    "effect_ranking_period"}, "the live thresholds, and no limit of the valve's")
            def adequacy():
                return self.diagnostic(target, "model adequacy")

            self.assertEqual(adequacy().level, DiagnosticStatus.OK, adequacy().message)
            error = target.comparison.get().simulation_error_rms
            lowered = client.update_configuration({"adequacy_warn_error": error / 4})
            self.assertAlmostEqual(lowered["adequacy_warn_error"], error / 4)
            wait_for(lambda: adequacy().level == DiagnosticStatus.WARN, 5,
                     "%smodel adequacy to warn above %.2f bar" % (target.ns, error / 4e5))
            self.assertIn("misses the pressure", adequacy().message)
            # A value the node refuses leaves the thresholds as they are, and the server says so.
            refused = client.update_configuration({"adequacy_warn_error": 0.0})
            self.assertAlmostEqual(refused["adequacy_warn_error"], error / 4)
            client.update_configuration({"adequacy_warn_error": 3e5})
            wait_for(lambda: adequacy().level == DiagnosticStatus.OK, 5, target.ns + "model adequacy OK again")

    def test_2_unsafe_and_invalid_sweeps_are_refused(self):
        for target in self.targets:
            wait_for(lambda: target.comparison.get() is not None and target.comparison.get().phase == 2, 10, "drawing")
            refused = target.start_sweep(frequencies=[], amplitude=0.0, offset=0.0, settle_periods=0.0,
                                         integration_periods=0.0)
            self.assertFalse(refused.success)
            self.assertIn("refused", refused.message)
            too_big = target.start_sweep(frequencies=[20.0], amplitude=5.0, offset=0.0, settle_periods=0.0,
                                         integration_periods=0.0)
            self.assertFalse(too_big.success)
            self.assertIn("sweep_max_amplitude", too_big.message)
            nyquist = target.start_sweep(frequencies=[900.0], amplitude=0.5, offset=0.0, settle_periods=0.0,
                                         integration_periods=0.0)
            self.assertFalse(nyquist.success)
            self.assertIn("Nyquist", nyquist.message)

    def test_3_set_effects_changes_the_model_and_the_error_shows_it(self):
        # Both targets change their model at once, so that they share the wait.
        with_leakage = {}
        for target in self.targets:
            with_leakage[target.ns] = target.comparison.get().simulation_error_rms
            bad = target.set_effects(effects=["no_such_effect"], custom_effects=[])
            self.assertFalse(bad.success)
            self.assertIn("no_such_effect", bad.message)
            base = target.set_effects(effects=[], custom_effects=[])
            self.assertTrue(base.success, base.message)
            self.assertEqual(list(base.parameters), ["bulk_modulus", "valve_flow_gain", "dead_volume"])
        changed = rospy.Time.now()
        wait_for(lambda: all(list(t.estimate.get().effects) == [] for t in self.targets), 5,
                 "the base model's estimates")
        # A ranking of the base model on four complete press cycles (about 12 s of the simulated press). Not a
        # fixed wait: under a loaded machine's scheduler the node ran behind the simulated clock, and its
        # ranking 12 s after the change had one cycle ("too few complete press cycles (1)").
        def ranked_base_model(target):
            ranking = target.ranking.get()
            return ranking is not None and ranking.header.stamp > changed and ranking.cycles >= 4
        wait_for(lambda: all(ranked_base_model(t) for t in self.targets), 60,
                 "a ranking of the base model on four press cycles")
        for target in self.targets:
            without_leakage = target.comparison.get().simulation_error_rms
            ranking = target.ranking.get()
            self.assertEqual(ranking.effects[0], "leakage", target.ns + ranking.conclusion)
            self.assertEqual(ranking.verdicts[0], "missing", ranking.explanations[0])
            self.assertNotIn("missing", ranking.verdicts[1:])
        rospy.sleep(1.5)  # the next diagnostics include the ranking
        for target in self.targets:
            adequacy = self.diagnostic(target, "model adequacy")
            self.assertIn(adequacy.level, (DiagnosticStatus.WARN, DiagnosticStatus.ERROR), adequacy.message)
            self.assertIn("misses the pressure", adequacy.message)
            self.assertIn("suspected missing effect: leakage", adequacy.message)
            without_leakage = target.comparison.get().simulation_error_rms
            self.assertGreater(without_leakage, 2.0 * with_leakage[target.ns],
                               "leaving out the plant's leakage must show in the error (%.2f vs %.2f bar)"
                               % (without_leakage * 1e-5, with_leakage[target.ns] * 1e-5))
            broken = target.set_effects(effects=["leakage"], custom_effects=["broken=p*("])
            self.assertFalse(broken.success)
            self.assertIn("broken", broken.message)
            custom = target.set_effects(effects=["leakage"], custom_effects=["bypass=p"])
            self.assertTrue(custom.success, custom.message)
            self.assertIn("bypass_theta", list(custom.parameters))

if __name__ == "__main__":
    rostest.rosrun("die_cushion_ident", "live_identification", LiveIdentification)
