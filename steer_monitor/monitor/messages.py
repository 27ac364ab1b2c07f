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
~/load_sharing                   sensor_msgs/JointState          named (``name`` and
                                                                 ``position``): lateral_n,
                                                                 ram_force_n, guide_force_n,
                                                                 k_gl, deflection_m, r_a_n,
                                                                 r_e_n, m_a_nm, case
~/clearances                     sensor_msgs/JointState          named: gap_2z_m, gap_2z_lo_m,
                                                                 gap_2z_hi_m, gap_2z_bounded,
                                                                 and the same for gap_zgb
                                                                 (NaN: no bound; bounded 1
                                                                 when both ends are known)
~/clearance_source               std_msgs/String                 configured / estimated
================================ ============================== ===========================

Named values ride in ``sensor_msgs/JointState`` (one name per value, in ``position``;
``velocity`` and ``effort`` NaN, not empty: rclpy's Fast-CDR pads an empty sequence of
doubles in a way rosbags refuses to read): a standard stamped message that PlotJuggler, Foxglove
and rosbags read by name, where a ``Float64MultiArray`` is read by index. A package of our
own message types would need colcon and a compiler on every shore computer that reads a
recording. Readers here also take the older ``Float64MultiArray`` form (labels in its
layout).
"""

from __future__ import annotations

import math
from typing import Any

from steer_monitor.can.mcapio import ros_time
from steer_monitor.monitor.diagnostics import Status
from steer_monitor.monitor.live import LiveState
from steer_monitor.monitor.pipeline import DiagOut, StateOut

__all__ = ['CLEARANCE_LABELS', 'CLEARANCE_LABELS_V1', 'LOAD_LABELS', 'TOPICS', 'diag_messages', 'state_messages',
           'stamp', 'topic_name']

LOAD_LABELS = ('lateral_n', 'ram_force_n', 'guide_force_n', 'k_gl', 'deflection_m', 'r_a_n', 'r_e_n',
               'm_a_nm', 'case')
CLEARANCE_LABELS = ('gap_2z_m', 'gap_2z_lo_m', 'gap_2z_hi_m', 'gap_2z_bounded',
                    'gap_zgb_m', 'gap_zgb_lo_m', 'gap_zgb_hi_m', 'gap_zgb_bounded')
#: the labels of recordings made before the clearances were named (Float64MultiArray)
CLEARANCE_LABELS_V1 = ('gap_2z_m', 'gap_2z_lo_m', 'gap_2z_hi_m', 'gap_zgb_m', 'gap_zgb_lo_m', 'gap_zgb_hi_m')

#: key -> (topic relative to the node, ROS datatype)
TOPICS = {
    'diagnostics': ('/diagnostics', 'diagnostic_msgs/msg/DiagnosticArray'),
    'rudder': ('~/rudder', 'sensor_msgs/msg/JointState'),
    'load_sharing': ('~/load_sharing', 'sensor_msgs/msg/JointState'),
    'clearances': ('~/clearances', 'sensor_msgs/msg/JointState'),
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


def _named(t_ns: int, labels: tuple[str, ...], values: list[float]) -> dict[str, Any]:
    """A JointState carrying ``values`` by name (see the module docstring)."""
    nan = [math.nan] * len(values)
    return {'header': {'stamp': stamp(t_ns), 'frame_id': 'steering_gear'}, 'name': list(labels),
            'position': values, 'velocity': nan, 'effort': nan}


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
        msgs.append(('load_sharing', st.t_ns, _named(st.t_ns, LOAD_LABELS, [
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

    def bounds(key: str) -> list[float]:
        lo, hi = (math.nan if v is None else float(v) for v in interval.get(key, (None, None)))
        return [lo, hi, 1.0 if math.isfinite(lo) and math.isfinite(hi) else 0.0]
    g = out.gaps
    return [('diagnostics', out.t_ns, {'header': {'stamp': stamp(out.t_ns), 'frame_id': ''}, 'status': statuses}),
            ('clearances', out.t_ns,
             _named(out.t_ns, CLEARANCE_LABELS, [g.two_z, *bounds('2z'), g.z_gb, *bounds('zgb')])),
            ('clearance_source', out.t_ns, {'data': out.source})]
