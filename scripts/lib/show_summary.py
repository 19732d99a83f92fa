#!/usr/bin/python3
"""Part of scripts/demo: prints the essentials of an analyze_bag summary.yaml."""
import sys

import yaml

summary = yaml.safe_load(open(sys.argv[1]))
what = sys.argv[2:] or ["fit", "candidates", "proposals", "valve"]
model, fit = summary["model"], summary["fit"]
if "fit" in what:
    print("  model: %s" % (", ".join(model["effects"]) or "base model"))
    for p in model["parameters"]:
        print("    %-22s %12.5g %s" % (p["name"], p["value"], p["unit"]))
    print("  free-run pressure error: %.2f bar rms over %d press cycles" % (fit["simulation_error_rms"] * 1e-5,
                                                                         fit["cycles"]))
    for sentence in fit["worst_regions"][:2]:
        print("  - " + sentence)
if "candidates" in what:
    print("  candidates (judged on held-out press cycles):")
    for c in summary["candidates"]:
        print("    %-14s %-12s %+5.0f %% error   %s" % (c["effect"], c["verdict"], -100 * c["error_reduction"],
                                                     c["explanation"].split(";")[0]))
    if summary.get("steps"):
        print("  steps (each verified on held-out cycles; the last is the recommended model):")
        for s in summary["steps"]:
            print("    + %-14s held-out error %.2f bar rms%s" % (s["add"], s["held_out_error_rms"] * 1e-5,
                                                           " (with %s)" % s["together_with"]
                                                           if s.get("together_with") else ""))
if "proposals" in what and summary.get("proposals"):
    print("  formulas for the error the library leaves:")
    for p in summary["proposals"]:
        print("    %-40s %-12s %+5.0f %% error   %s" % (p["expression"], p["verdict"], -100 * p["error_reduction"],
                                                     p["explanation"].split(";")[0]))
if "candidates" in what:
    print("  conclusion: " + summary["adequacy"]["conclusion"])
if "valve" in what and summary.get("valve"):
    v = summary["valve"]
    print("  valve (sweep found in the recording): %.1f Hz, damping %.2f, gain %.3g 1/V, dead time %.2f ms"
          % (v["natural_frequency"], v["damping"], v["gain"], v["dead_time"] * 1e3))
