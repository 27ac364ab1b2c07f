"""Recordings rosbag2 takes as its own: each channel's offered QoS and type hash, the
``rosbag2`` metadata record, checked with an independent reader of rosbag2 bags (rosbags):
its type hashes, and the bag's metadata read by its rosbag2 reader."""

from __future__ import annotations

import pytest
import yaml

from steer_monitor.ashore.replay import add_channels
from steer_monitor.can.frames import Frame
from steer_monitor.logfiles.mcapio import FRAME_DATATYPE, FRAME_MSGDEF, FRAME_TOPIC, McapWriter
from steer_monitor.logfiles.rosbag2meta import offered_qos_profiles
from steer_monitor.logfiles.typehash import type_hash
from steer_monitor.monitor.messages import TOPICS, topic_name
from steer_monitor.record.cdr import FAST_ENCODERS
from steer_monitor.record.msgdefs import msgdef

T0 = 1_767_225_600_000_000_000


def _store():
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    store = get_typestore(Stores.ROS2_KILTED)
    store.register(get_types_from_msg(FRAME_MSGDEF.split('=' * 80)[0], FRAME_DATATYPE))
    return store


@pytest.mark.parametrize('datatype', sorted({dt for _, dt in TOPICS.values()} | {FRAME_DATATYPE}))
def test_the_type_hash_is_rosbags(datatype):
    """Every type a recording holds: the hash from its definition text, as rosbags computes it
    from its own type store (the frame's from its text)."""
    text = FRAME_MSGDEF if datatype == FRAME_DATATYPE else msgdef(datatype)
    assert type_hash(datatype, text) == _store().hash_rihs01(datatype)


def test_a_constant_and_an_array_bound_change_the_hash_as_rosidl_reads_them():
    base = 'uint8 a\nfloat64[3] b\nstring<=5 c\nint32[] d\nint16[<=4] e'
    assert type_hash('p/msg/T', base) == type_hash('p/msg/T', 'uint8 X=1\n' + base + '  # a comment')
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    store = get_typestore(Stores.ROS2_KILTED)
    store.register(get_types_from_msg(base, 'p/msg/T'))
    assert type_hash('p/msg/T', base) == store.hash_rihs01('p/msg/T')
    assert type_hash('p/msg/T', base.replace('[3]', '[4]')) != type_hash('p/msg/T', base)


def _write(path, n_frames=30):
    """A file as replay writes one: the node's topics (a message on each) and frames."""
    with McapWriter(path) as w:
        topics = {key: topic_name(key, 'steer_monitor') for key in TOPICS}
        add_channels(w, topics, True)
        w.write_frames([Frame(T0 + k * 10_000_000, 0x09F10D10, bytes(8)) for k in range(n_frames)])
        w.write_cdr(topics['clearance_source'], FAST_ENCODERS['std_msgs/msg/String']({'data': 'configured'}),
                    T0 + 5_000_000)
        w.write_cdr(topics['clearance_source'], FAST_ENCODERS['std_msgs/msg/String']({'data': 'estimated'}),
                    T0 + 400_000_000)
    return topics


def test_the_channels_and_the_bag_metadata(tmp_path):
    from mcap.reader import make_reader
    path = tmp_path / 'r.mcap'
    topics = _write(path)
    with open(path, 'rb') as fh:
        reader = make_reader(fh)
        summary = reader.get_summary()
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    by_topic = {c.topic: c for c in summary.channels.values()}
    clear = by_topic[topics['clearances']].metadata
    assert yaml.safe_load(clear['offered_qos_profiles'])[0]['durability'] == 'transient_local'
    assert yaml.safe_load(by_topic['/diagnostics'].metadata['offered_qos_profiles'])[0]['depth'] == 10
    assert clear['topic_type_hash'] == _store().hash_rihs01('sensor_msgs/msg/JointState')
    bag = yaml.safe_load(meta['rosbag2']['serialized_metadata'])
    assert bag['version'] == 9 and bag['storage_identifier'] == 'mcap' and bag['relative_file_paths'] == []
    assert bag['message_count'] == 32 and bag['starting_time'] == {'nanoseconds_since_epoch': T0}
    assert bag['duration'] == {'nanoseconds': 400_000_000}
    counts = {t['topic_metadata']['name']: t['message_count'] for t in bag['topics_with_message_count']}
    assert counts == {**{t: 0 for t in topics.values()}, FRAME_TOPIC: 30, topics['clearance_source']: 2}


def test_rosbags_reads_the_recording_as_a_rosbag2_bag(tmp_path):
    """The file with the metadata.yaml its ``rosbag2`` record holds, the file named in it (as
    ``ros2 bag reindex`` would write it), is a bag rosbags' rosbag2 reader opens: topics, counts, type hashes and
    offered QoS as recorded, the messages read back."""
    from mcap.reader import make_reader
    from rosbags.interfaces import QosDurability
    from rosbags.rosbag2 import Reader
    bag = tmp_path / 'bag'
    bag.mkdir()
    topics = _write(bag / 'r.mcap')
    with open(bag / 'r.mcap', 'rb') as fh:
        serialized = {m.name: m.metadata for m in make_reader(fh).iter_metadata()}['rosbag2']['serialized_metadata']
    info = yaml.safe_load(serialized) | {'relative_file_paths': ['r.mcap']}     # reindex names the files it finds
    (bag / 'metadata.yaml').write_text(yaml.safe_dump({'rosbag2_bagfile_information': info}), encoding='utf-8')
    store = _store()
    with Reader(bag) as r:
        conns = {c.topic: c for c in r.connections}
        assert r.message_count == 32 and r.duration == 400_000_001
        assert conns[FRAME_TOPIC].msgcount == 30 and conns[topics['clearance_source']].msgcount == 2
        assert {c.topic: c.digest for c in r.connections} == {c.topic: store.hash_rihs01(c.msgtype)
                                                                 for c in r.connections}
        assert conns[topics['clearances']].ext.offered_qos_profiles[0].durability == QosDurability.TRANSIENT_LOCAL
        got = [store.deserialize_cdr(raw, c.msgtype).data for c, _, raw in r.messages()
               if c.topic == topics['clearance_source']]
    assert got == ['configured', 'estimated']


def test_the_offered_qos_text():
    profile = yaml.safe_load(offered_qos_profiles(1, True))[0]
    assert (profile['history'], profile['depth'], profile['reliability'], profile['durability']) == (
        'keep_last', 1, 'reliable', 'transient_local')
