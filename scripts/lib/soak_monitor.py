#!/usr/bin/python3
"""Part of scripts/soak: samples the nodelet manager (memory, CPU), the estimates and the diagnostics
every simulated 10 minutes, and judges them at the end."""
import os
import sys
import threading
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray

from die_cushion_ident.msg import ParameterEstimate

pid, hours, out = int(sys.argv[1]), float(sys.argv[2]), sys.argv[3]
LEVELS = {0: "OK", 1: "WARN", 2: "ERROR", 3: "STALE"}
lock = threading.Lock()
latest = {"estimate": None, "diagnostics": {}}


def on_estimate(msg):
    with lock:
        latest["estimate"] = msg


def on_diagnostics(msg):
    with lock:
        for s in msg.status:
            latest["diagnostics"][s.name.split(": ", 1)[-1]] = s.level


def rss_mb():
    with open("/proc/%d/status" % pid) as f:
        for line in f:
            if line.startswith("VmRSS"):
                return int(line.split()[1]) / 1024.0
    return float("nan")


def cpu_seconds():
    fields = open("/proc/%d/stat" % pid).read().split(")")[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


rospy.init_node("soak_monitor", anonymous=True)
rospy.Subscriber("/die_cushion/ident/estimate", ParameterEstimate, on_estimate, queue_size=1)
rospy.Subscriber("/diagnostics", DiagnosticArray, on_diagnostics, queue_size=10)
while not rospy.is_shutdown() and rospy.Time.now().to_sec() < 1000.5:
    time.sleep(0.1)
start_sim = rospy.Time.now().to_sec()
start_wall, start_cpu = time.time(), cpu_seconds()
samples = []
log = open(os.path.join(out, "soak.csv"), "w")
log.write("sim_hours,wall_s,rss_mb,cpu_share,bulk_modulus,valve_flow_gain,dead_volume,leakage_conductance,levels\n")
next_sample = start_sim
while not rospy.is_shutdown():
    now = rospy.Time.now().to_sec()
    if now >= next_sample:
        next_sample += 600.0
        with lock:
            e = latest["estimate"]
            levels = dict(latest["diagnostics"])
        values = list(e.values) if e else [float("nan")] * 4
        wall = time.time() - start_wall
        cpu = (cpu_seconds() - start_cpu) / max(wall, 1e-9)
        sim_hours = (now - start_sim) / 3600.0
        row = (sim_hours, wall, rss_mb(), cpu, values, levels)
        samples.append(row)
        log.write("%.3f,%.1f,%.1f,%.3f,%s,%s\n" % (sim_hours, wall, row[2], cpu, ",".join("%.6g" % v for v in values),
                                                   " ".join("%s=%s" % (k.replace(" ", "_"), LEVELS.get(v, v)) for k, v in sorted(levels.items()))))
        log.flush()
        print("  %5.2f h simulated, %6.0f s wall: RSS %.1f MB, CPU %.0f %% of a core, bulk modulus %.4g Pa" % (sim_hours, wall, row[2], 100 * cpu, values[0]), flush=True)
        if sim_hours >= hours:
            break
    time.sleep(0.5)

rss = [s[2] for s in samples]
settled = rss[len(rss) // 10:] or rss
growth = settled[-1] - settled[0]
bulk = [s[4][0] for s in samples[1:]]
bounded = all(abs(b - 1.2e9) / 1.2e9 < 0.05 for b in bulk)
errors = sum(1 for s in samples[1:] for level in s[5].values() if level >= 2)
print()
print("| soak, %.1f simulated hours | figure |" % samples[-1][0])
print("| --- | --- |")
print("| wall time, speed | %.0f s, %.0fx real time |" % (samples[-1][1], samples[-1][0] * 3600 / samples[-1][1]))
print("| manager (simulator + identification) RSS | start %.1f MB, end %.1f MB, max %.1f MB; after the first 10 %%: %+.1f MB |" % (rss[0], rss[-1], max(rss), growth))
print("| manager CPU | %.0f %% of one core (simulator included) |" % (100 * samples[-1][3]))
print("| bulk modulus over the run | %.4g ... %.4g Pa (truth 1.2e9), %s |" % (min(bulk), max(bulk), "within 5 %" if bounded else "NOT within 5 %"))
print("| diagnostics at ERROR in samples after the first | %d |" % errors)
print("verdict: memory %s, estimates %s, diagnostics %s" % ("flat" if abs(growth) < 20 else "GROWING", "bounded" if bounded else "NOT bounded", "steady" if errors == 0 else "NOT steady"))
