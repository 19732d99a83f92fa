"""What the valve fault-injection rostests share (issue 45): a simulated press this test starts, kills and
faults itself, a recorder of every valve-driving output as it arrives here (on the steady clock), and the
checks every case makes on what was recorded."""
import math
import signal
import subprocess
import threading
import time

import rospy

from die_cushion_ident.msg import ValveSignal
from die_cushion_ident.srv import InjectFault
from rostest_helpers import tool

# [s] the bound the issue sets for a sweep's command to be back at its offset after the bus died, measured
# from outside on valve_command: the supervision timeout (50 ms) plus the watchdog's period and transport.
SAFE_BOUND = 0.1
# The identification's namespace in the fault tests, and the sweep they start (5 frequencies, about 2.9 s).
NS = "/die_cushion/ident/"
SWEEP = dict(frequencies=[20.0, 40.0, 60.0, 80.0, 100.0], amplitude=0.3, settle_periods=0.0,
             integration_periods=0.0)


class Press:
    """A simulator_node in /die_cushion, run as a process of this test so that it can be killed mid-case."""

    def __init__(self, **params):
        # Private parameters given as _key:=value stay on the parameter server: a press started before would
        # leave its own (at_rest) to the next.
        if rospy.has_param("/die_cushion/simulator"):
            rospy.delete_param("/die_cushion/simulator")
        args = [tool("simulator_node"), "__ns:=/die_cushion", "__name:=simulator"]
        args += ["_%s:=%s" % (key, value) for key, value in params.items()]
        self.process = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        rospy.wait_for_service("/die_cushion/simulator/inject_fault", timeout=30)
        self._inject = rospy.ServiceProxy("/die_cushion/simulator/inject_fault", InjectFault)

    def inject(self, silence_inputs=False, stop_clock=False, stamp_offset=0.0):
        response = self._inject(silence_inputs=silence_inputs, stop_clock=stop_clock, stamp_offset=stamp_offset)
        assert response.success, response.message

    def kill(self):
        """SIGKILL: every publisher of the press stops at once, as when a bus coupler dies."""
        if self.process.poll() is None:
            self.process.send_signal(signal.SIGKILL)
            self.process.wait(timeout=10)


class Recorder:
    """Every message of valve_command and ~feed_forward, and the arrival of the press's messages, each with
    the steady time it arrived here."""

    def __init__(self, ns):
        self.lock = threading.Lock()
        self.commands, self.feed_forward = [], []  # (arrival, V)
        self.feed_forward_stamped = []  # (stamp [s, ROS time when sent], V)
        self.commands_stamped = []  # (stamp [s, ROS time when sent], V)
        self.last_input = 0.0  # arrival of the press's newest valve message
        self.subs = [
            rospy.Subscriber("/die_cushion/valve_command", ValveSignal, self._on, self.commands, queue_size=10000,
                             tcp_nodelay=True),
            rospy.Subscriber(ns + "feed_forward", ValveSignal, self._on, self.feed_forward, queue_size=10000,
                             tcp_nodelay=True),
            rospy.Subscriber("/die_cushion/valve", ValveSignal, self._on_input, queue_size=10000, tcp_nodelay=True),
        ]

    def _on(self, msg, into):
        with self.lock:
            into.append((time.monotonic(), msg.voltage))
            stamped = self.feed_forward_stamped if into is self.feed_forward else self.commands_stamped
            stamped.append((msg.header.stamp.to_sec(), msg.voltage))

    def _on_input(self, _):
        with self.lock:
            self.last_input = time.monotonic()

    def snapshot(self):
        with self.lock:
            return list(self.commands), list(self.feed_forward), self.last_input

    def stamped_feed_forward(self):
        with self.lock:
            return list(self.feed_forward_stamped)

    def stamped_commands(self):
        with self.lock:
            return list(self.commands_stamped)


def wait_until(predicate, timeout, what):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline and not rospy.is_shutdown():
        if predicate():
            return
        time.sleep(0.02)
    raise AssertionError("timed out (%.0f s) waiting for %s" % (timeout, what() if callable(what) else what))


def start_when_at_rest(start, timeout=20.0, **request):
    """Calls a start service until the node's interlocks accept it (the cushion settling, inputs arriving)."""
    deadline = time.monotonic() + timeout
    response = None
    while time.monotonic() < deadline:
        response = start(**request)
        if response.success:
            return response
        time.sleep(0.2)
    raise AssertionError("never started: %s" % (response.message if response else "no response"))


def _final_run_at(commands, offset):
    """The index of the first command of the recording's final run of commands at `offset` (None where the
    last command is not at it). A sweep's own command can equal its offset to the last bit, at the start of
    each frequency (phase 0), so the hand-back is the run at the offset that nothing but the offset follows,
    not the first command at it."""
    at = [abs(voltage - offset) < 1e-9 for _, voltage in commands]
    if not at or not at[-1]:
        return None
    i = len(at) - 1
    while i > 0 and at[i - 1]:
        i -= 1
    return i


def sweep_running(recorder, offset, within=0.05):
    """Whether the sweep still drives the valve: its newest command, off the offset, arrived within `within`
    seconds. Under load the node's watchdog may already have stopped it (its command timer stalled for more
    than the supervision timeout, a correct reaction): then a fault injected now would test nothing."""
    commands, _, _ = recorder.snapshot()
    return bool(commands) and time.monotonic() - commands[-1][0] <= within and abs(commands[-1][1] - offset) >= 1e-9


def back_at_offset_after(commands, fault, offset):
    """[s] from `fault` to the hand-back to `offset` (the first command of the final run at it; the command at
    the fault's moment where the run began before), and the commands after the hand-back (none: it is sent
    once). inf where the commands after the fault do not end at the offset."""
    after_fault = [c for c in commands if c[0] >= fault]
    i = _final_run_at(after_fault, offset)
    if i is None:
        return math.inf, []
    return after_fault[i][0] - fault, after_fault[i + 1:]


def handed_back_around(commands, fault, offset, lag):
    """[s] from `fault` to the sweep's hand-back to `offset` (the first command of the final run at it after a
    command that is not), found from `lag` seconds before `fault` on: a fault this process notices on one
    subscription (a /clock at 1 kHz, queued behind its own callbacks under load) may come after the node's
    reaction arrived on another. 0 where the hand-back arrived before the fault was noticed; inf where there
    is none in that window."""
    window = [c for c in commands if c[0] >= fault - lag]
    i = _final_run_at(window, offset)
    if not i:  # no final run at the offset, or no command before it in the window that was not
        return math.inf
    return max(window[i][0] - fault, 0.0)


def check_limits(case, messages, low, high):
    for _, voltage in messages:
        case.assertTrue(math.isfinite(voltage) and low - 1e-9 <= voltage <= high + 1e-9,
                        "a command of %r V outside [%g, %g] V" % (voltage, low, high))


def check_slew(case, feed_forward_stamped, slew_rate, jitter=0.0005):
    """No step of the feed-forward larger than its slew rate allows in the time between the messages' stamps
    (when each was sent; their arrivals here bunch up), and never more than one step of 10 ms."""
    for (t0, u0), (t1, u1) in zip(feed_forward_stamped, feed_forward_stamped[1:]):
        allowed = slew_rate * min(t1 - t0 + jitter, 0.01) + 1e-9
        case.assertLessEqual(abs(u1 - u0), allowed, "a step of %.4f V in %.2f ms" % (u1 - u0, (t1 - t0) * 1e3))


def check_one_output_at_a_time(case, commands_stamped, feed_forward_stamped, offsets=()):
    """An experiment's command (other than a hand-back to an offset) is never decided while the feed-forward's
    last message was other than 0 V. Judged on the stamps, the moment the supervisor decided each message under
    its one lock (SupervisedValve::publish), not on arrival here: the two topics come over two connections,
    and under load one of them arrived more than 20 ms after the other (the feed-forward's 0 V after the
    experiment's first command that the supervisor decided after it)."""
    for stamp, voltage in commands_stamped:
        if any(abs(voltage - offset) < 1e-9 for offset in offsets):
            continue
        # Within one topic the order is the order sent: the last message stamped at or before the command.
        before = [u for t, u in feed_forward_stamped if t <= stamp]
        case.assertTrue(not before or before[-1] == 0.0,
                        "an experiment's %.3f V decided at %.4f s while the feed-forward adds %.3f V"
                        % (voltage, stamp, before[-1] if before else 0))
