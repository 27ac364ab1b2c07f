"""The monitor's outputs as ROS 2 messages, written as plain dicts of their fields. Pure.

The node turns these into rclpy messages and publishes them; ``steer-monitor replay``
encodes the same dicts to CDR for its MCAP. One builder, so live and replay cannot drift.
Standard interfaces only (no interface package to build):

================================ ====================================== ======================
topic (under the node's name)    type                                   content
================================ ====================================== ======================
/diagnostics                     diagnostic_msgs/DiagnosticArray         one status per concern,
                                                                         each whole second of data
~/rudder                         sensor_msgs/JointState                  joint ``rudder``: position
                                                                         [rad], velocity [rad/s],
                                                                         effort = tiller torque
                                                                         from the pressures [N m]
~/load_sharing                   sensor_msgs/JointState                  named values
                                                                         (``LOAD_SHARING_NAMES``)
                                                                         in ``position``
~/clearances                     sensor_msgs/JointState                  named values
                                                                         (``CLEARANCE_NAMES``) in
                                                                         ``position`` [m], NaN: not
                                                                         known
~/clearance_source               std_msgs/String                         configured / estimated
================================ ====================================== ======================

A ``JointState`` is the standard message with a header stamp and named float64 values:
PlotJuggler plots each value by its name (``/steer_monitor/clearances/gap_zgb_m/position``),
Foxglove by its place in the fixed order (``/steer_monitor/clearances.position[3]``).
Recordings made by earlier releases carried the load sharing and clearances as
``steer_monitor_msgs`` types (their schemas are in the MCAP) or a labelled
``std_msgs/Float64MultiArray``; the report reads them all
(:func:`steer_monitor.ashore.report.reviewpage.published_track`).
"""

from __future__ import annotations

import math
from typing import Any

from steer_monitor.monitor.diagnostics import Status
from steer_monitor.monitor.live import LiveState
from steer_monitor.monitor.pipeline import DiagOut, StateOut
from steer_monitor.rostime import ros_time

__all__ = ['CLEARANCE_NAMES', 'DEPTH', 'LATCHED', 'LOAD_SHARING_NAMES', 'TOPICS', 'diag_messages', 'stamp',
           'state_messages', 'topic_name', 'topic_qos']

#: the named values of ``~/clearances`` (and of older recordings' labelled Float64MultiArray):
#: 2Z and the ends of its 95 % interval, Z_gb and the ends of its [m]; NaN where not known
#: (an upper end for a clearance the data bound from below only; both ends for a configured one)
CLEARANCE_NAMES = ('gap_2z_m', 'gap_2z_lo_m', 'gap_2z_hi_m', 'gap_zgb_m', 'gap_zgb_lo_m', 'gap_zgb_hi_m')
#: the named values of ``~/load_sharing``: lateral force on one ram's crosshead, the part the
#: ram carries and the part the guide beam carries [N], K_gl, the ram's deflection at the
#: load point [m], the bushing reactions [N] and the clamp moment [N m], the paper's load case
#: (1..6) and the stages that carried load (bit flags: I = 1, II = 2, III = 4)
LOAD_SHARING_NAMES = ('lateral_n', 'ram_force_n', 'guide_force_n', 'k_gl', 'deflection_m', 'r_a_n', 'r_e_n',
                      'm_a_nm', 'load_case', 'stages')

#: key -> (topic relative to the node, ROS datatype)
TOPICS = {
    'diagnostics': ('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray'),
    'rudder': ('~/rudder', 'sensor_msgs/msg/JointState'),
    'load_sharing': ('~/load_sharing', 'sensor_msgs/msg/JointState'),
    'clearances': ('~/clearances', 'sensor_msgs/msg/JointState'),
    'clearance_source': ('~/clearance_source', 'std_msgs/msg/String'),
}

#: the outputs whose last message a late subscriber gets at once (transient_local, depth 1:
#: the estimate in use and its source, which change seldom; a dashboard started after the node
#: should not wait for the next analysis)
LATCHED = frozenset({'clearances', 'clearance_source'})
#: the history depth of the other outputs' publishers
DEPTH = 10


def topic_qos(key: str) -> tuple[int, bool]:
    """An output's publisher QoS: (history depth, transient_local), reliable: what the node
    offers and what its recordings and replays say it offered."""
    return (1, True) if key in LATCHED else (DEPTH, False)


def topic_name(key: str, node_name: str = 'steer_monitor', namespace: str = '/') -> str:
    """The resolved topic of an output (``~/rudder`` -> ``/steer_monitor/rudder``)."""
    rel = TOPICS[key][0]
    if rel.startswith('~/'):
        ns = namespace.rstrip('/')
        return f'{ns}/{node_name}/{rel[2:]}'
    return rel


def stamp(t_ns: int) -> dict[str, int]:
    """A header stamp; unset (0, 0) outside ROS time's int32 seconds (see ``ros_time``)."""
    sec, nanosec = ros_time(t_ns)
    return {'sec': sec, 'nanosec': nanosec}


def _header(t_ns: int, frame_id: str = 'steering_gear') -> dict[str, Any]:
    return {'stamp': stamp(t_ns), 'frame_id': frame_id}


def _named(t_ns: int, names: tuple[str, ...], values: list[float], frame_id: str = 'steering_gear') -> dict[str, Any]:
    """A ``sensor_msgs/JointState`` of named values (``position``; no velocity or effort)."""
    return {'header': _header(t_ns, frame_id), 'name': list(names), 'position': values, 'velocity': [], 'effort': []}


def _with_bounds(value: float, bounds: tuple[float | None, float | None]) -> list[float]:
    """A value and the ends of its interval, NaN for an end not known."""
    lo, hi = (math.nan if v is None else float(v) for v in bounds)
    return [float(value), lo, hi]


def state_messages(out: StateOut) -> list[tuple[str, int, dict[str, Any]]]:
    """(key, log time [ns], message) of a state: the rudder joint and, once all four
    pressures are known, the load sharing."""
    st: LiveState = out.state
    msgs: list[tuple[str, int, dict[str, Any]]] = [('rudder', st.t_ns, {
        'header': _header(st.t_ns, 'rudder_stock'),
        'name': ['rudder'], 'position': [st.alpha], 'velocity': [st.rate],
        'effort': [math.copysign(st.torque_measured or 0.0, st.alpha)]})]
    if st.share is not None:
        sh = st.share
        msgs.append(('load_sharing', st.t_ns, _named(st.t_ns, LOAD_SHARING_NAMES, [
            sh.lateral, sh.ram_force, sh.guide_force, sh.k_gl, sh.deflection, sh.r_a, sh.r_e, sh.m_a,
            float(sh.case), float(sh.stages)])))
    return msgs


def diag_messages(out: DiagOut, extra: tuple[Status, ...] = ()) -> list[tuple[str, int, dict[str, Any]]]:
    """(key, log time [ns], message) of a diagnostics round: the array (with ``extra``
    statuses, e.g. the node's recording), the clearances in use and their source."""
    statuses = [{'level': s.level, 'name': s.name, 'message': s.message, 'hardware_id': s.hardware_id,
                 'values': [{'key': k, 'value': v} for k, v in s.values]}
                for s in (*out.statuses, *extra)]
    interval = out.interval or {}
    g = out.gaps
    return [('diagnostics', out.t_ns, {'header': _header(out.t_ns, ''), 'status': statuses}),
            ('clearances', out.t_ns, _named(out.t_ns, CLEARANCE_NAMES,
                                            _with_bounds(g.two_z, interval.get('2z', (None, None)))
                                            + _with_bounds(g.z_gb, interval.get('zgb', (None, None))))),
            ('clearance_source', out.t_ns, {'data': out.source})]
