"""What rosbag2's MCAP storage writes beside the messages, so ``ros2 bag info`` and ``ros2 bag
play`` take a recording as one of their own. Pure.

Each channel carries ``offered_qos_profiles`` (the QoS its publisher offered, YAML, the form of
rosbag2's metadata version 9) and ``topic_type_hash`` (:mod:`~steer_monitor.logfiles.typehash`);
the file ends with a ``rosbag2`` metadata record whose ``serialized_metadata`` is the bag's
metadata (rosbag2_storage's ``BagMetadata``, version 9): its one file, its span, its topics with
their message counts.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import yaml

__all__ = ['METADATA_NAME', 'VERSION', 'TopicCount', 'offered_qos_profiles', 'serialized_metadata']

#: the MCAP metadata record rosbag2 reads the bag's metadata from, and its version
METADATA_NAME = 'rosbag2'
VERSION = 9
#: a duration the DDS layer reports as infinite (deadline, lifespan, lease), as rosbag2 records it
_INFINITE = {'sec': 9223372036, 'nsec': 854775807}


def offered_qos_profiles(depth: int, transient_local: bool) -> str:
    """One reliable keep-last publisher of ``depth``, transient_local or volatile."""
    profile = {'history': 'keep_last', 'depth': int(depth), 'reliability': 'reliable',
               'durability': 'transient_local' if transient_local else 'volatile',
               'deadline': dict(_INFINITE), 'lifespan': dict(_INFINITE), 'liveliness': 'automatic',
               'liveliness_lease_duration': dict(_INFINITE), 'avoid_ros_namespace_conventions': False}
    return yaml.safe_dump([profile], sort_keys=False)


@dataclass(frozen=True)
class TopicCount:
    """A topic of the file: its name, type, offered QoS (YAML text), type hash and messages."""

    name: str
    datatype: str
    qos: str
    type_hash: str
    messages: int


def serialized_metadata(topics: Sequence[TopicCount], start_ns: int, end_ns: int, ros_distro: str = '') -> str:
    """The ``serialized_metadata`` of a one-file bag holding ``topics`` from ``start_ns`` to
    ``end_ns`` (log times, [ns]; both 0 for an empty file). The file is not named in it
    (``relative_file_paths`` and ``files`` empty): rosbag2 names it from the path it opens, and
    a recording's bytes do not depend on its name (a replay written twice under two names is
    the same file)."""
    count = sum(t.messages for t in topics)
    span = max(0, end_ns - start_ns)
    meta = {
        'version': VERSION, 'storage_identifier': 'mcap',
        'duration': {'nanoseconds': span}, 'starting_time': {'nanoseconds_since_epoch': start_ns},
        'message_count': count,
        'topics_with_message_count': [
            {'topic_metadata': {'name': t.name, 'type': t.datatype, 'serialization_format': 'cdr',
                                'offered_qos_profiles': yaml.safe_load(t.qos) or [],
                                'type_description_hash': t.type_hash},
             'message_count': t.messages} for t in topics],
        'compression_format': '', 'compression_mode': '',
        'relative_file_paths': [], 'files': [],
        'custom_data': {}, 'ros_distro': ros_distro,
    }
    return yaml.safe_dump(meta, sort_keys=False)
