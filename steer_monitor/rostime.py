"""ROS time (``builtin_interfaces/Time``) from integer nanoseconds: one place for its range."""

from __future__ import annotations

__all__ = ['SEC_MAX', 'ros_time']

#: ROS time's seconds are an int32
SEC_MAX = (1 << 31) - 1


def ros_time(t_ns: int) -> tuple[int, int]:
    """(sec, nanosec) of a ``builtin_interfaces/Time`` for ``t_ns`` [ns since 1970].

    ROS time holds seconds in an int32, so it ends on 2038-01-19 (and starts in 1901). A time
    outside that is stamped (0, 0), ROS's "unset"; the MCAP record's log time (uint64 ns)
    still carries it, and every reader here takes the log time when the stamp is unset."""
    sec, nsec = divmod(int(t_ns), 1_000_000_000)
    if not -SEC_MAX - 1 <= sec <= SEC_MAX:
        return 0, 0
    return sec, nsec
