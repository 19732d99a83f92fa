#!/usr/bin/python3
"""Part of scripts/demo: talks to the running simulator and identification nodes and prints what a user
would look at: estimates against the simulator's truth, the diagnostics, a valve sweep's result."""
import sys
import threading

import rospy
from diagnostic_msgs.msg import DiagnosticArray

from die_cushion_ident.msg import ModelComparison, ParameterEstimate, ValveModel
from die_cushion_ident.srv import SetEffects, StartSweep

NODE = "/die_cushion/ident/"
LEVELS = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}


def latest(topic, msg_type, timeout=30.0):
    return rospy.wait_for_message(topic, msg_type, timeout=timeout)


def show_estimates():
    estimate = latest(NODE + "estimate", ParameterEstimate)
    truth = latest("/die_cushion/simulator/truth", ParameterEstimate)
    true_values = dict(zip(truth.names, truth.values))
    print("  %-22s %14s %12s %14s %8s" % ("parameter", "identified", "std", "true", "error"))
    for name, value, std, unit in zip(estimate.names, estimate.values, estimate.standard_deviations,
                                      estimate.units):
        true = true_values.get(name)
        error = "%+.2f %%" % (100 * (value / true - 1)) if true else "-"
        print("  %-22s %14.5g %12.2g %14s %8s  %s" % (name, value, std, "%.5g" % true if true else "-", error,
                                                      unit))
    comparison = latest(NODE + "model_comparison", ModelComparison)
    print("  free-run pressure error %.2f bar rms, one-step dp/dt error %.0f bar/s rms"
          % (comparison.simulation_error_rms * 1e-5, comparison.equation_error_rms * 1e-5))


def show_diagnostics():
    statuses = {}
    deadline = rospy.Time.now() + rospy.Duration(5.0)
    while len(statuses) < 6 and rospy.Time.now() < deadline:
        array = latest("/diagnostics", DiagnosticArray)
        for s in array.status:
            statuses[s.name] = s
    for name in sorted(statuses):
        s = statuses[name]
        print("  %-5s %-40s %s" % (LEVELS.get(s.level, s.level), name, s.message))


def sweep():
    start = rospy.ServiceProxy(NODE + "start_sweep", StartSweep)
    rospy.wait_for_service(NODE + "start_sweep", timeout=30)
    response = start(frequencies=[], amplitude=0.0, offset=0.1, settle_periods=0.0, integration_periods=0.0)
    print("  start_sweep: %s" % response.message)
    if not response.success:
        return
    model = latest(NODE + "valve_model", ValveModel, timeout=response.expected_duration + 30.0)
    truth = latest("/die_cushion/simulator/valve_truth", ValveModel)
    print("  %-20s %12s %10s %10s" % ("valve parameter", "identified", "std", "true"))
    for name, unit, scale in [("natural_frequency", "Hz", 1.0), ("damping", "-", 1.0), ("gain", "1/V", 1.0),
                              ("dead_time", "ms", 1e3)]:
        print("  %-20s %12.4g %10.2g %10.4g  %s" % (name, getattr(model, name) * scale,
                                                     getattr(model, name + "_std") * scale,
                                                     getattr(truth, name) * scale, unit))
    print("  %s" % model.message)


def set_effects(effects):
    proxy = rospy.ServiceProxy(NODE + "set_effects", SetEffects)
    rospy.wait_for_service(NODE + "set_effects", timeout=30)
    response = proxy(effects=effects, custom_effects=[])
    print("  set_effects %s: %s" % (effects, response.message))


def wait(seconds):
    rospy.sleep(seconds)


if __name__ == "__main__":
    rospy.init_node("demo", anonymous=True)
    for command in sys.argv[1:]:
        name, _, argument = command.partition("=")
        if name == "estimates":
            show_estimates()
        elif name == "diagnostics":
            show_diagnostics()
        elif name == "sweep":
            sweep()
        elif name == "effects":
            set_effects([e for e in argument.split(",") if e])
        elif name == "wait":
            wait(float(argument))
