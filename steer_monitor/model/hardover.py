"""Hard-over time and the pumps that ran it, from the Rapson slide's kinematics.

A pump moves the ram at v (``ram_speed_per_pump``); the ram's travel for rudder angle a is
H tan a (H: stock to ram), so the rudder turns at n v cos^2(a) / H with n pumps, and a
hard-over from ``from_deg`` on one side to ``to_deg`` on the other takes
H (tan from + tan to) / (n v). The pumps that ran a measured hard-over are the nearest whole
number to the one-pump time over the measured one. Pure.
"""

from __future__ import annotations

import math

__all__ = ['HARD_OVER_FROM_DEG', 'HARD_OVER_TO_DEG', 'hard_over_time', 'pumps_running']

#: where a hard-over is timed from and to, as the monitor reads SOLAS's 35 and 30 deg (with
#: room for sensor noise and the valve's dead band)
HARD_OVER_FROM_DEG = 34.5
HARD_OVER_TO_DEG = 29.5


def hard_over_time(stock_to_ram: float, ram_speed: float, pumps: int = 1,
                   from_deg: float = HARD_OVER_FROM_DEG, to_deg: float = HARD_OVER_TO_DEG) -> float:
    """Seconds for ``pumps`` pumps at ``ram_speed`` [m/s each] to turn the rudder from
    ``from_deg`` one side to ``to_deg`` the other; ``stock_to_ram`` [m]."""
    if not (stock_to_ram > 0 and ram_speed > 0 and pumps >= 1):
        msg = f'hard-over time needs H > 0, v > 0 and pumps >= 1, got {stock_to_ram}, {ram_speed}, {pumps}'
        raise ValueError(msg)
    return stock_to_ram * (math.tan(math.radians(from_deg)) + math.tan(math.radians(to_deg))) / (pumps * ram_speed)


def pumps_running(seconds: float, stock_to_ram: float, ram_speed: float, pumps: int) -> int:
    """The whole number of pumps (1 .. ``pumps``) whose hard-over time is nearest to
    ``seconds`` on the scale of speed (one-pump time over ``seconds``, rounded)."""
    one = hard_over_time(stock_to_ram, ram_speed)
    return int(min(max(round(one / max(seconds, 1e-9)), 1), pumps))
