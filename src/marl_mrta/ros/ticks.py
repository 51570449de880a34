"""The simulator's physics ticks in sim time (ROS-free): one rule for the executor and the
stock_lockstep nodes."""
from __future__ import annotations

import math


def first_tick_at(stamp: float, physics_rate: float) -> int:
    """The first physics tick at or after `stamp` s of sim time. A millionth of a tick of slack
    keeps a stamp that sits on a tick, but carries float error, on that tick and not the next."""
    return int(math.ceil(stamp * physics_rate - 1e-6))


def sim_elapsed(since: float, until: float) -> float:
    """Sim time from `since` to `until`, in whole nanoseconds as ros::Time counts it: the plain
    difference of two absolute times in seconds carries their rounding, which depends on when
    the run started (a 46.7 s episode came out as 46.700000000000045 s in a launch that started
    later)."""
    return round((until - since) * 1e9) / 1e9
