"""The monitor's outputs as ROS 2 messages, written as plain dicts of their fields. Pure.

The node turns these into rclpy messages and publishes them; ``steer-monitor replay``
encodes the same dicts to CDR for its MCAP. One builder, so live and replay cannot drift.

================================ ====================================== ======================
topic (under the node's name)    type                                   content
================================ ====================================== ======================
/diagnostics                     diagnostic_msgs/DiagnosticArray         one status per concern,
                                                                         each whole second of data
~/rudder                         sensor_msgs/JointState                  joint ``rudder``: position
                                                                         [rad], velocity [rad/s],
                                                                         effort = tiller torque
                                                                         from the pressures [N m]
~/load_sharing                   steer_monitor_msgs/LoadSharing          lateral_n, ram_force_n,
                                                                         guide_force_n, k_gl,
                                                                         deflection_m, r_a_n, r_e_n,
                                                                         m_a_nm, load_case, stages
~/clearances                     steer_monitor_msgs/Clearances           gap_2z_m, gap_zgb_m: each
                                                                         value, lo, hi (NaN: not
                                                                         known) and bounded
~/clearance_source               std_msgs/String                         configured / estimated
================================ ====================================== ======================

The message types are in ``steer_monitor_msgs`` (beside this package; ``make venv`` builds it
with colcon). Only the node needs them built: a recording embeds their definitions, so
rosbags, Foxglove and ``steer-monitor report`` read it without them, and ``replay`` encodes
them itself (:mod:`steer_monitor.record.cdr`) from the ``.msg`` files. Recordings made before
these types carry the clearances as named ``sensor_msgs/JointState`` values or a labelled
``std_msgs/Float64MultiArray``; the report reads those too
(:func:`steer_monitor.ashore.report.logreport.online_track`).
"""

from __future__ import annotations

import math
from typing import Any

from steer_monitor.can.mcapio import ros_time
from steer_monitor.monitor.diagnostics import Status
from steer_monitor.monitor.live import LiveState
from steer_monitor.monitor.pipeline import DiagOut, StateOut

__all__ = ['CLEARANCE_LABELS_V1', 'TOPICS', 'diag_messages', 'state_messages', 'stamp', 'topic_name']

#: the value names of older recordings' clearances (a labelled Float64MultiArray, then named
#: values in a JointState): 2Z and its bounds, Z_gb and its bounds [m]
CLEARANCE_LABELS_V1 = ('gap_2z_m', 'gap_2z_lo_m', 'gap_2z_hi_m', 'gap_zgb_m', 'gap_zgb_lo_m', 'gap_zgb_hi_m')

#: key -> (topic relative to the node, ROS datatype)
TOPICS = {
    'diagnostics': ('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray'),
    'rudder': ('~/rudder', 'sensor_msgs/msg/JointState'),
    'load_sharing': ('~/load_sharing', 'steer_monitor_msgs/msg/LoadSharing'),
    'clearances': ('~/clearances', 'steer_monitor_msgs/msg/Clearances'),
    'clearance_source': ('~/clearance_source', 'std_msgs/msg/String'),
}


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


def _estimate(value: float, bounds: tuple[float | None, float | None]) -> dict[str, Any]:
    """A ``steer_monitor_msgs/Estimate``: NaN for an end not known."""
    lo, hi = (math.nan if v is None else float(v) for v in bounds)
    return {'value': float(value), 'lo': lo, 'hi': hi, 'bounded': math.isfinite(lo) and math.isfinite(hi)}


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
        msgs.append(('load_sharing', st.t_ns, {
            'header': _header(st.t_ns), 'lateral_n': sh.lateral, 'ram_force_n': sh.ram_force,
            'guide_force_n': sh.guide_force, 'k_gl': sh.k_gl, 'deflection_m': sh.deflection, 'r_a_n': sh.r_a,
            'r_e_n': sh.r_e, 'm_a_nm': sh.m_a, 'load_case': int(sh.case), 'stages': int(sh.stages)}))
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
            ('clearances', out.t_ns, {'header': _header(out.t_ns),
                                      'gap_2z_m': _estimate(g.two_z, interval.get('2z', (None, None))),
                                      'gap_zgb_m': _estimate(g.z_gb, interval.get('zgb', (None, None)))}),
            ('clearance_source', out.t_ns, {'data': out.source})]
