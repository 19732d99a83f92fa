#!/usr/bin/python3
"""Review by attack (issue 45), claims (4) and (6): test_valve_faults' random interleaving of every service,
harder -- eight caller threads with at most 20 ms between calls (the suite: three, up to 300 ms), for 20 s,
meant to be run under CPU load (two busy loops on the 2 cores). Asserts as the suite does on valve_command and
~feed_forward: within the limits, the feed-forward's slew, one output at a time; and that the node still
answers (no deadlock) after it."""
import random
import threading
import time
import unittest

import rospy
import rostest
from sensor_msgs.msg import FluidPressure

from die_cushion_ident.msg import ParameterEstimate
from die_cushion_ident.srv import AbortSweep, Reset, SetEffects, SetFeedForward, StartStepTest, StartSweep
from rostest_helpers import Latest
from valve_faults_common import (NS, SWEEP, Press, Recorder, check_limits, check_one_output_at_a_time, check_slew,
                                 wait_until)

VOLTAGE, SLEW = 3.0, 20.0


class ValveFaultsStress(unittest.TestCase):
    def test_eight_threads_of_random_services(self):
        rospy.init_node("test_valve_faults_stress")
        recorder = Recorder(NS)
        for name in ["start_sweep", "abort_sweep", "start_step_test", "enable_feed_forward", "reset", "set_effects"]:
            rospy.wait_for_service(NS + name, timeout=60)
        press = Press(seed=9, rest_time=2.5)
        setpoint = rospy.Publisher("/die_cushion/pressure_setpoint", FluidPressure, queue_size=1000)
        stop = threading.Event()

        def stream():
            while not stop.is_set():
                setpoint.publish(FluidPressure(header=rospy.Header(stamp=rospy.Time.now()), fluid_pressure=60e5))
                time.sleep(0.005)

        offsets, lock, calls = {0.0}, threading.Lock(), [0]

        def caller(seed):
            rng = random.Random(seed)
            proxies = dict(sweep=rospy.ServiceProxy(NS + "start_sweep", StartSweep),
                           step=rospy.ServiceProxy(NS + "start_step_test", StartStepTest),
                           abort=rospy.ServiceProxy(NS + "abort_sweep", AbortSweep),
                           ff=rospy.ServiceProxy(NS + "enable_feed_forward", SetFeedForward),
                           reset=rospy.ServiceProxy(NS + "reset", Reset),
                           effects=rospy.ServiceProxy(NS + "set_effects", SetEffects))
            while not stop.is_set():
                action = rng.random()
                offset = round(rng.uniform(-1.0, 1.0), 3)
                try:
                    if action < 0.4:
                        with lock:
                            offsets.add(offset)
                    if action < 0.2:
                        proxies["sweep"](offset=offset, **SWEEP)
                    elif action < 0.4:
                        proxies["step"](offset=offset, step=rng.uniform(-0.8, 0.8), duration=0.3, settle=0.1)
                    elif action < 0.55:
                        proxies["abort"]()
                    elif action < 0.8:
                        proxies["ff"](enable=rng.random() < 0.6)
                    elif action < 0.9:
                        proxies["reset"]()
                    else:
                        proxies["effects"](effects=rng.choice([[], ["leakage"], ["entrained_air"]]), custom_effects=[])
                    with lock:
                        calls[0] += 1
                except rospy.ServiceException:
                    pass
                time.sleep(rng.uniform(0.0, 0.02))

        threading.Thread(target=stream, daemon=True).start()
        # The feed-forward engaged first (the estimator identified the stroking press), so that the races
        # are between an engaged feed-forward and the experiments.
        estimate = Latest(NS + "estimate", ParameterEstimate)
        wait_until(lambda: estimate.get() is not None and estimate.get().updates > 300, 90, "the estimator")
        wait_until(lambda: any(abs(u) > 0.05 for _, u in recorder.snapshot()[1][-50:]), 60,
                   "the feed-forward to engage")
        threads = [threading.Thread(target=caller, args=(seed,), daemon=True) for seed in range(8)]
        try:
            for t in threads:
                t.start()
            time.sleep(20.0)
        finally:
            stop.set()
            for t in threads:
                t.join(timeout=10)
        self.assertFalse(any(t.is_alive() for t in threads), "a service call hangs: the node deadlocked")
        self.assertTrue(rospy.ServiceProxy(NS + "abort_sweep", AbortSweep)() is not None)
        time.sleep(0.5)
        press.kill()
        commands, ff, _ = recorder.snapshot()
        print("8 threads: %d service calls, %d valve commands, %d feed-forward messages (max |ff| %.3f V)"
              % (calls[0], len(commands), len(ff), max([abs(u) for _, u in ff] or [0.0])))
        check_limits(self, commands, -VOLTAGE, VOLTAGE)
        check_limits(self, ff, -VOLTAGE, VOLTAGE)
        check_slew(self, recorder.stamped_feed_forward(), SLEW)
        with lock:
            check_one_output_at_a_time(self, recorder.stamped_commands(), recorder.stamped_feed_forward(),
                                       offsets=sorted(offsets))


if __name__ == "__main__":
    rostest.rosrun("die_cushion_ident", "valve_faults_stress", ValveFaultsStress)
