"""The controller side of the simulator's lock-step protocol (docs/reference/nodes_sim_nav.md).

For every /simulator/tick the controller publishes its commands for that tick on each
robot's cmd_vel, then one marl_mrta/LockstepAck per robot carrying the number of commands
sent so far; the simulator advances only when every robot in its ~lockstep_robots has been
answered and those commands have arrived. Results then never depend on machine load. A
controller acting every `period` seconds of sim time says so in its acks (next_stamp), and the
simulator runs through the ticks in between without waiting for it.
"""
from __future__ import annotations

import math
import threading
import time
from typing import Callable, Dict, Optional, Sequence

import rospy
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry

from marl_mrta.msg import LockstepAck, SimTick


class LockstepController:
    """Drives `robots` (namespaces) in lock-step with the simulator.

    `on_tick(tick_msg, states)` is called once per new tick, with `states` the robots' latest
    `state_topic` messages (Odometry) stamped at that tick (state_topic None: no states); it
    sends commands with `command()` and returns False to stop answering (the simulator then
    waits at that tick). The states are waited for up to state_wait_wall seconds, so the
    simulator's odom_rate should equal its physics_rate (the default) when states are used.
    With `period` > 0 [sim s], `on_tick` is called only for the first tick of each period counted
    from time 0, and the simulator does not wait for the ticks in between.
    """

    def __init__(self, robots: Sequence[str], on_tick: Callable[[SimTick, Dict[str, Odometry]], bool],
                 state_topic: Optional[str] = "base_pose_ground_truth", state_wait_wall: float = 1.0,
                 period: float = 0.0):
        self.robots = list(robots)
        self.period = period
        self._acted_period: Optional[int] = None
        self.on_tick = on_tick
        self.state_wait_wall = state_wait_wall
        self._state_topic = state_topic
        self.commands_sent = {ns: 0 for ns in self.robots}
        self.finished = threading.Event()
        self._answered_tick = -1
        self._stopped = False
        self._states: Dict[str, Odometry] = {}
        self._state_changed = threading.Condition()
        self._cmd_pubs = {ns: rospy.Publisher(ns + "/cmd_vel", Twist, queue_size=100) for ns in self.robots}
        self._ack_pub = rospy.Publisher("/simulator/lockstep_ack", LockstepAck, queue_size=100)
        self._tick_sub = None
        if state_topic:
            for ns in self.robots:
                rospy.Subscriber("%s/%s" % (ns, state_topic), Odometry, self._on_state, ns, queue_size=50,
                                 tcp_nodelay=True)

    def start(self, timeout_wall: float = 60.0) -> None:
        """Waits until the simulator listens to every cmd_vel and to the acks (a command sent
        before would be lost, yet counted), then starts answering ticks."""
        deadline = time.monotonic() + timeout_wall
        publishers = [self._ack_pub] + list(self._cmd_pubs.values())
        while not all(p.get_num_connections() > 0 for p in publishers):
            if rospy.is_shutdown() or time.monotonic() > deadline:
                raise RuntimeError("lock-step: the simulator did not subscribe to cmd_vel / lockstep_ack in %.0f s"
                                   % timeout_wall)
            time.sleep(0.05)  # wall time: sim time does not run before the first answer
        # No Nagle delay: every tick is a round trip of small messages.
        self._tick_sub = rospy.Subscriber("/simulator/tick", SimTick, self._on_tick, queue_size=10, tcp_nodelay=True)

    def command(self, ns: str, linear: float, angular: float) -> None:
        """Sends a cmd_vel to robot `ns` for the tick being answered."""
        twist = Twist()
        twist.linear.x, twist.angular.z = linear, angular
        self._cmd_pubs[ns].publish(twist)
        self.commands_sent[ns] += 1

    def _on_state(self, msg: Odometry, ns: str) -> None:
        with self._state_changed:
            self._states[ns] = msg
            self._state_changed.notify_all()

    def _states_at(self, stamp: rospy.Time) -> Dict[str, Odometry]:
        """The robots' states stamped at `stamp`: they travel on other connections than the tick
        and may arrive just after it. After state_wait_wall, the latest ones are used."""
        if not self._state_topic:
            return {}
        deadline = time.monotonic() + self.state_wait_wall
        with self._state_changed:
            while True:
                ready = all(ns in self._states and self._states[ns].header.stamp >= stamp for ns in self.robots)
                remaining = deadline - time.monotonic()
                if ready or remaining <= 0:
                    return dict(self._states)
                self._state_changed.wait(remaining)

    def _on_tick(self, msg: SimTick) -> None:
        if self._stopped:
            return
        next_stamp = rospy.Time()  # 0: every tick is needed
        act = True
        if self.period > 0.0:
            index = math.floor(msg.stamp.to_sec() / self.period + 1e-6)
            next_stamp = rospy.Time.from_sec((index + 1 - 1e-6) * self.period)
            act = index != self._acted_period
        if msg.tick != self._answered_tick:
            if act:
                if not self.on_tick(msg, self._states_at(msg.stamp)):
                    self._stopped = True
                    self.finished.set()
                    return
                if self.period > 0.0:
                    self._acted_period = index
            self._answered_tick = msg.tick
        # A re-sent tick is answered again: the first answer may have gone before the
        # simulator's subscription was connected.
        for ns in self.robots:
            self._ack_pub.publish(LockstepAck(robot=ns, tick=msg.tick, cmd_vel_count=self.commands_sent[ns],
                                              next_stamp=next_stamp))
