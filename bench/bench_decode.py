"""Decode of a one-hour simulated log: the per-frame path (cantools, one Frame at a time, as
live) and the batch path (numpy over arrays), side by side in one run. Each rate is also given
as a multiple of 1,908 frames/s, what a saturated 250 kbit/s NMEA 2000 bus carries.

Two measurements each: decode alone (frames already in memory), and read + decode from a
candump .log file: read frame by frame by python-can's reader (``can.CanutilsLogReader``, the
library's candump parser) or by the package's column reader.
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path

import can

from steer_monitor import sim
from steer_monitor.can import Decoder, collect
from steer_monitor.can.bus import frame_from_message
from steer_monitor.can.busconfig import can_setup
from steer_monitor.can.frames import FrameArrays
from steer_monitor.logfiles.blocks import read_log_fast
from steer_monitor.logfiles.logs import LogWriter
from steer_monitor.params import load_params_file
from steer_monitor.resources import default_config

BUS_RATE = 1908.0
PROGRAM = 'voyage,voyage,autopilot:610'  # about one hour


def _rate(n: int, seconds: float) -> str:
    r = n / seconds
    return f'{r:12,.0f} frames/s  = {r / BUS_RATE:8.1f} x bus'


def main() -> dict:
    config = default_config()
    params = load_params_file(config)
    db, smap = can_setup(params, config)
    s = sim.run(params, sim.SimConfig(program=PROGRAM), db, smap, seed=1)
    fa = s.frames
    frames = fa.frames('can0')
    n = len(fa)
    hours = (int(fa.t_ns[-1]) - int(fa.t_ns[0])) / 3.6e12

    t0 = time.perf_counter()
    d = Decoder(db, smap)
    per = collect((x for f in frames for x in d.decode(f)), smap.names)
    per_s = time.perf_counter() - t0

    t0 = time.perf_counter()
    batch = Decoder(db, smap).decode_arrays(fa)
    batch_s = time.perf_counter() - t0
    assert all(len(per[k]) == len(batch[k]) for k in smap.names), 'paths disagree'

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / 'hour.log'
        with LogWriter(path) as w:
            for f in frames:
                w.write(f)
        t0 = time.perf_counter()
        d = Decoder(db, smap)
        for msg in can.CanutilsLogReader(str(path)):
            d.decode(frame_from_message(msg))
        file_per_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        Decoder(db, smap).decode_arrays(FrameArrays.from_frames(map(frame_from_message,
                                                                    can.CanutilsLogReader(str(path)))))
        file_lines_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        Decoder(db, smap).decode_arrays(read_log_fast(path))
        file_batch_s = time.perf_counter() - t0

    print(f'decode of a {hours:.2f} h simulated log, {n:,} frames')
    print(f'  in memory, per frame : {per_s:7.2f} s  {_rate(n, per_s)}')
    print(f'  in memory, batch     : {batch_s:7.2f} s  {_rate(n, batch_s)}')
    print(f'  in memory, batch / per-frame = {per_s / batch_s:,.0f}x')
    print(f'  candump file, python-can\'s reader, decoded per frame : {file_per_s:7.2f} s  {_rate(n, file_per_s)}')
    print(f'  candump file, python-can\'s reader, decoded as columns : {file_lines_s:7.2f} s  '
          f'{_rate(n, file_lines_s)}')
    print(f'  candump file, column reader (logfiles/candumpcols.py) + batch decode: {file_batch_s:7.2f} s  '
          f'{_rate(n, file_batch_s)}')
    print(f'  candump file, column reader + batch / python-can + per frame = {file_per_s / file_batch_s:,.0f}x')
    return {'frames': n, 'per_frame_s': per_s, 'batch_s': batch_s, 'file_per_frame_s': file_per_s,
            'file_lines_s': file_lines_s, 'file_batch_s': file_batch_s}


if __name__ == '__main__':
    main()
