"""The monitor's outputs as ROS 2 messages, written as plain dicts of their fields. Pure.

The node turns these into rclpy messages and publishes them; ``steer-monitor replay``
encodes the same dicts to CDR for its MCAP. One builder, so live and replay cannot drift.

================================ ============================== ===========================
topic (under the node's name)    type                           content
================================ ============================== ===========================
/diagnostics                     diagnostic_msgs/DiagnosticArray one status per concern, each
                                                                 whole second of data
~/rudder                         sensor_msgs/JointState          joint ``rudder``: position
                                                                 [rad], velocity [rad/s],
                                                                 effort = tiller torque from
                                                                 the pressures [N m]
~/load_sharing                   std_msgs/Float64MultiArray      labelled: lateral_n,
                                                                 ram_force_n, guide_force_n,
                                                                 k_gl, deflection_m, r_a_n,
                                                                 r_e_n, m_a_nm, case
~/clearances                     std_msgs/Float64MultiArray      labelled: gap_2z_m, lo, hi,
                                                                 gap_zgb_m, lo, hi (NaN: none)
~/clearance_source               std_msgs/String                 configured / estimated
================================ ============================== ===========================
"""

from __future__ import annotations

import math
from typing import Any

from steer_monitor.can.mcapio import ros_time
from steer_monitor.monitor.diagnostics import Status
from steer_monitor.monitor.live import LiveState
from steer_monitor.monitor.pipeline import DiagOut, StateOut

__all__ = ['CLEARANCE_LABELS', 'LOAD_LABELS', 'TOPICS', 'diag_messages', 'state_messages', 'stamp', 'topic_name']

LOAD_LABELS = ('lateral_n', 'ram_force_n', 'guide_force_n', 'k_gl', 'deflection_m', 'r_a_n', 'r_e_n',
               'm_a_nm', 'case')
CLEARANCE_LABELS = ('gap_2z_m', 'gap_2z_lo_m', 'gap_2z_hi_m', 'gap_zgb_m', 'gap_zgb_lo_m', 'gap_zgb_hi_m')

#: key -> (topic relative to the node, ROS datatype)
TOPICS = {
    'diagnostics': ('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray'),
    'rudder': ('~/rudder', 'sensor_msgs/msg/JointState'),
    'load_sharing': ('~/load_sharing', 'std_msgs/msg/Float64MultiArray'),
    'clearances': ('~/clearances', 'std_msgs/msg/Float64MultiArray'),
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


def _array(labels: tuple[str, ...], data: list[float]) -> dict[str, Any]:
    return {'layout': {'dim': [{'label': ','.join(labels), 'size': len(labels), 'stride': len(labels)}],
                       'data_offset': 0},
            'data': data}


def state_messages(out: StateOut) -> list[tuple[str, int, dict[str, Any]]]:
    """(key, log time [ns], message) of a state: the rudder joint and, once all four
    pressures are known, the load sharing."""
    st: LiveState = out.state
    msgs: list[tuple[str, int, dict[str, Any]]] = [('rudder', st.t_ns, {
        'header': {'stamp': stamp(st.t_ns), 'frame_id': 'rudder_stock'},
        'name': ['rudder'], 'position': [st.alpha], 'velocity': [st.rate],
        'effort': [math.copysign(st.torque_measured or 0.0, st.alpha)]})]
    if st.share is not None:
        sh = st.share
        msgs.append(('load_sharing', st.t_ns, _array(LOAD_LABELS, [
            sh.lateral, sh.ram_force, sh.guide_force, sh.k_gl, sh.deflection, sh.r_a, sh.r_e, sh.m_a,
            float(sh.case)])))
    return msgs


def diag_messages(out: DiagOut, extra: tuple[Status, ...] = ()) -> list[tuple[str, int, dict[str, Any]]]:
    """(key, log time [ns], message) of a diagnostics round: the array (with ``extra``
    statuses, e.g. the node's recording), the clearances in use and their source."""
    statuses = [{'level': s.level, 'name': s.name, 'message': s.message, 'hardware_id': s.hardware_id,
                 'values': [{'key': k, 'value': v} for k, v in s.values]}
                for s in (*out.statuses, *extra)]
    interval = out.interval or {}

    def bound(key: str, i: int) -> float:
        v = interval.get(key, (None, None))[i]
        return math.nan if v is None else float(v)
    g = out.gaps
    return [('diagnostics', out.t_ns, {'header': {'stamp': stamp(out.t_ns), 'frame_id': ''}, 'status': statuses}),
            ('clearances', out.t_ns, _array(CLEARANCE_LABELS, [g.two_z, bound('2z', 0), bound('2z', 1),
                                                               g.z_gb, bound('zgb', 0), bound('zgb', 1)])),
            ('clearance_source', out.t_ns, {'data': out.source})]
