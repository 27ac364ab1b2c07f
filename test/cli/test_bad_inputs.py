"""Every subcommand over a corpus of bad inputs: one line on stderr naming what was wrong,
exit 1 (2 for usage), never a traceback, nothing half-written, nothing readable lost.

The corpus is made from a short simulated log and recording: empty, junk, truncated at many
offsets, flipped bytes, reversed lines, odd whitespace, a 5 MB line, non-UTF-8 bytes, one
far-future frame, times past 2038, corrupt MCAP chunks (CRC and compression), cut BLF and
ASC logs, bad output paths, bad YAML (non-UTF-8, deep nesting, an alias bomb, a list, junk).

One module of some 630 lines: one corpus, built once per session, and the one rule it is
held to (``_check``) for every command."""

from __future__ import annotations

import io
import json
import random
import re
from pathlib import Path

import pytest

from steer_monitor.cli.main import main
from test.conftest import PKG

LOG_COMMANDS = ('inspect', 'analyze', 'report', 'replay')


@pytest.fixture(scope='module')
def base(tmp_path_factory) -> dict[str, Path]:
    """A 20 s simulated candump log and MCAP, a 70 s MCAP with small uncompressed chunks
    (for CRC damage) and a replay recording of the short log."""
    d = tmp_path_factory.mktemp('base')
    for name in ('short.log', 'short.mcap'):
        assert main(['simulate', '--program', 'hard_over_2', '--max-duration', '20', '--seed', '3',
                     '--out', str(d / name)]) == 0
    assert main(['simulate', '--program', 'hard_over_2', '--seed', '3', '--out', str(d / 'long.log')]) == 0
    _uncompressed_mcap(d / 'long.log', d / 'chunks.mcap')
    assert main(['replay', str(d / 'short.log'), '--out', str(d / 'rec.mcap')]) == 0
    return {'log': d / 'short.log', 'mcap': d / 'short.mcap', 'chunks': d / 'chunks.mcap', 'rec': d / 'rec.mcap',
            'long': d / 'long.log'}


def _uncompressed_mcap(log: Path, out: Path) -> None:
    """The frames of ``log`` in an MCAP of 8 KiB uncompressed chunks (with CRCs): a flipped
    byte inside one changes a frame silently unless the CRC is checked."""
    from mcap.writer import CompressionType, Writer

    from steer_monitor.logfiles.blocks import read_log_fast
    from steer_monitor.logfiles.mcapio import DEFAULT_QOS, FRAME_DATATYPE, FRAME_MSGDEF, FRAME_TOPIC, frame_cdr
    fa = read_log_fast(log)
    with open(out, 'wb') as fh:
        w = Writer(fh, chunk_size=8192, compression=CompressionType.NONE, enable_crcs=True)
        w.start(profile='ros2', library='test')
        sid = w.register_schema(FRAME_DATATYPE, 'ros2msg', FRAME_MSGDEF.encode())
        cid = w.register_channel(FRAME_TOPIC, 'cdr', sid, {'offered_qos_profiles': DEFAULT_QOS})
        for f in fa.frames():
            w.add_message(cid, log_time=f.t_ns, publish_time=f.t_ns, data=frame_cdr(f))
        w.finish()


def _chunk_spans(path: Path) -> list[tuple[int, int]]:
    """(start, end) byte offsets of the chunk records' data in an MCAP."""
    import struct
    b = path.read_bytes()
    pos, out = 8, []
    while pos + 9 <= len(b):
        op, ln = struct.unpack_from('<BQ', b, pos)
        if op == 0x06:
            out.append((pos + 9 + 40, pos + 9 + ln))   # past the chunk header, to its end
        if op in (0x0F, 0x02):
            break
        pos += 9 + ln
    return out


def _run(capsys, argv: list[str]) -> tuple[int, list[str], str]:
    try:
        rc = main(argv)
    except SystemExit as exc:       # argparse: usage errors
        rc = exc.code
    captured = capsys.readouterr()
    lines = [line for line in captured.err.splitlines() if line.strip()]
    return rc, lines, captured.out


def _argv(command: str, path: Path, out: Path) -> list[str]:
    return {'inspect': ['inspect', str(path), '--json', '-'],
            'analyze': ['analyze', str(path), '--json', str(out / 'a.json')],
            'report': ['report', str(path), '--out', str(out / 'page'), '--analysis-hours', '0'],
            'replay': ['replay', str(path), '--out', str(out / 'r.mcap'), '--no-frames'],
            'recover': ['recover', str(path), '--out', str(out / 'rc.mcap')]}[command]


def _no_temporaries(root: Path) -> None:
    left = [p for p in root.rglob('*') if '.tmp' in p.name]
    assert not left, left


def _check(capsys, command: str, path: Path, out: Path, want_rc: int | None, want: str | None) -> list[str]:
    out.mkdir(exist_ok=True)
    rc, lines, _ = _run(capsys, _argv(command, path, out))
    assert rc in (0, 1), (command, path.name, rc, lines)
    assert not any('Traceback' in line or 'internal error' in line for line in lines), lines
    if rc:      # one line of error (notes, such as the parameters a recording was replayed with, aside)
        errors = [line for line in lines if f'steer-monitor {command}: note: ' not in line]
        assert len(errors) == 1 and errors[0].startswith(f'steer-monitor {command}: error: '), lines
        lines = errors
    if want_rc is not None:
        assert rc == want_rc, (command, path.name, lines)
    if want is not None:
        assert any(want in line for line in lines), (command, path.name, lines)
    _no_temporaries(out)
    return lines


def _flip(data: bytes, n: int, lo: int, hi: int, seed: int) -> bytes:
    rng = random.Random(seed)
    b = bytearray(data)
    for _ in range(n):
        b[rng.randrange(lo, hi)] ^= 0xFF
    return bytes(b)


CANDUMP_CASES = {
    # name: (bytes from the good log, inspect's exit status)
    'empty': (lambda b: b'', 1),
    'junk': (lambda b: random.Random(5).randbytes(4000), 1),
    # every frame but the first goes back in time: no rudder angle left, refused as every command refuses it
    'reversed': (lambda b: b'\n'.join(reversed(b.splitlines())) + b'\n', 1),
    'crlf_tabs': (lambda b: b.replace(b' ', b' \t ').replace(b'\n', b'\r\n'), 0),
    'huge_line': (lambda b: b[:3000] + b'x' * 5_000_000 + b'\n' + b[3000:], 0),
    'non_utf8': (lambda b: b[:3000] + b'\xff\xfe\x80' + b[3000:], 0),
    'flipped': (lambda b: _flip(b, 64, 0, len(b), 1), 0),
    'future_frame': (lambda b: b[:6000] + b'(4102444800.000000) can0 09F10D10#00F80000FFFFFFFF\n' + b[6000:], 0),
    'past_2038': (lambda b: b.replace(b'(1767', b'(2267'), 0),
}


@pytest.mark.parametrize('case', sorted(CANDUMP_CASES))
def test_bad_candump_logs(base, tmp_path, capsys, case):
    make, inspect_rc = CANDUMP_CASES[case]
    path = tmp_path / f'{case}.log'
    path.write_bytes(make(base['log'].read_bytes()))
    (tmp_path / 'o1').mkdir()
    rc, lines, out = _run(capsys, _argv('inspect', path, tmp_path / 'o1'))
    assert rc == inspect_rc, lines
    assert len(out) < 100_000          # a 5 MB line is not a 5 MB example
    if case == 'empty':                # what it holds is printed, and the one line says why it is refused
        assert lines == [f'steer-monitor inspect: error: no frame in {path}'], lines
    elif case == 'junk':
        assert re.fullmatch(rf'steer-monitor inspect: error: no frame in {re.escape(str(path))} '
                            r'\(rejected: \d+ malformed_record\)', lines[0]) and len(lines) == 1, lines
    elif case == 'reversed':           # the frames are there, the rudder angle is not: said as analyze says it
        assert lines == [f'steer-monitor inspect: error: {path}: no rudder angle in the data (input rudder_angle): '
                         'nothing to estimate from'], lines
    else:
        assert not lines, lines
    assert (json.loads(out)['frames'] == 0) == (case in ('empty', 'junk'))
    lines = _check(capsys, 'replay', path, tmp_path / 'o2', None, None)
    if case in ('empty', 'junk'):
        assert lines == [f'steer-monitor replay: error: no frame in {path}']
        assert not (tmp_path / 'o2' / 'r.mcap').exists()
    if case == 'reversed':
        assert lines == [f'steer-monitor replay: error: {path}: no rudder angle in the data (input rudder_angle): '
                         'nothing to estimate from']
        assert not (tmp_path / 'o2' / 'r.mcap').exists()


def test_one_far_future_frame_costs_that_frame_only(base, tmp_path, capsys):
    """A glitched rudder frame 75 years ahead poisoned its identifier
    (every later frame time_backwards) and made the grids span decades."""
    lines = base['long'].read_bytes().splitlines(keepends=True)
    rudder = next(line for line in lines[2000:] if b' 09F10D10#' in line)
    glitch = b'(4102444800.000000) can0 ' + rudder.split(b' can0 ', 1)[1]
    path = tmp_path / 'glitch.log'
    path.write_bytes(b''.join(lines[:2000]) + glitch + b''.join(lines[2000:]))
    got = {}
    for p in (base['long'], path):
        rc, _, out = _run(capsys, ['inspect', str(p), '--json', '-'])
        assert rc == 0
        got[p] = json.loads(out)
    g, b = got[base['long']], got[path]
    assert b['rejects'] == {**g['rejects'], 'time_jump': 1}
    assert b['signals']['rudder_angle']['samples'] == g['signals']['rudder_angle']['samples']
    assert b['span_s'] == g['span_s']


def test_corrupt_chunk_is_skipped_counted_and_reported(base, tmp_path, capsys):
    """Flipped bytes inside an uncompressed chunk: without the CRC the frames would pass on
    altered. Every reader refuses that chunk, keeps the chunks before and after it, and says
    so; recover drops it and says why."""
    good = base['chunks'].read_bytes()
    spans = _chunk_spans(base['chunks'])
    assert len(spans) > 10
    lo, hi = spans[len(spans) // 2]
    path = tmp_path / 'flipped.mcap'
    path.write_bytes(_flip(good, 8, lo + 100, hi - 100, 2))
    rc, lines, out = _run(capsys, ['inspect', str(path), '--json', '-'])
    assert rc == 1 and len(lines) == 1 and '1 corrupt chunk(s) skipped' in lines[0] and 'CRC mismatch' in lines[0]
    s = json.loads(out)
    rc, _, ref = _run(capsys, ['inspect', str(base['chunks']), '--json', '-'])
    r = json.loads(ref)
    assert s['rejects'].get('corrupt_chunk') == 1
    assert 0 < r['frames'] - s['frames'] < 200                # one chunk's frames, the rest kept
    assert s['end_ns'] == r['end_ns'] and s['start_ns'] == r['start_ns']
    out_dir = tmp_path / 'o'
    _check(capsys, 'replay', path, out_dir, 1, 'corrupt chunk')
    assert (out_dir / 'r.mcap').stat().st_size > 0             # made from what could be read
    lines = _check(capsys, 'recover', path, out_dir, 1, 'corrupt chunk(s) dropped')
    assert 'CRC mismatch' in lines[0]


@pytest.mark.parametrize('where', ['zstd', 'recording'])
def test_flipped_compressed_chunk(base, tmp_path, capsys, where):
    src = base['mcap'] if where == 'zstd' else base['rec']
    lo, hi = _chunk_spans(src)[0]
    path = tmp_path / f'{where}.mcap'
    path.write_bytes(_flip(src.read_bytes(), 64, lo + 50, hi - 50, 3))
    for command in ('inspect', 'replay'):
        lines = _check(capsys, command, path, tmp_path / command, 1, None)
        assert ': 1 corrupt chunk(s) skipped (byte ' in lines[0] and 'zstd data broken' in lines[0], lines
        assert lines[0].endswith('the frames before and after them were read'), lines
    _check(capsys, 'recover', path, tmp_path / 'rc', 1, None)


def test_a_corrupt_first_chunk_does_not_lose_the_channels_it_defined(base, tmp_path, capsys):
    """The first chunk holds the schemas and channels: corrupt, it made every later frame
    of the file unreadable ('no CAN frames'). A finished file repeats them in its summary,
    which is read first: only that chunk's frames are lost."""
    src = base['chunks']
    lo, hi = _chunk_spans(src)[0]
    path = tmp_path / 'first.mcap'
    path.write_bytes(_flip(src.read_bytes(), 16, lo + 50, hi - 50, 5))
    rc, lines, out = _run(capsys, ['inspect', str(path), '--json', '-'])
    assert rc == 1 and len(lines) == 1 and '1 corrupt chunk(s) skipped' in lines[0], lines
    got, ref = json.loads(out), json.loads(_run(capsys, ['inspect', str(src), '--json', '-'])[2])
    assert 0 < ref['frames'] - got['frames'] < ref['frames'] // 2, (got['frames'], ref['frames'])
    lines = _check(capsys, 'replay', path, tmp_path / 'o', 1, 'corrupt chunk')
    # recover too: it took the definitions from the data only, and its copy held no frame
    _check(capsys, 'recover', path, tmp_path / 'rc', 1, 'corrupt chunk(s) dropped')
    rc, _, out = _run(capsys, ['inspect', str(tmp_path / 'rc' / 'rc.mcap'), '--json', '-'])
    assert rc == 0 and json.loads(out)['frames'] == got['frames']


@pytest.mark.parametrize('size', [300 << 20, 1 << 44])
def test_a_chunk_declaring_an_absurd_size_is_refused_before_it_is_inflated(base, tmp_path, capsys, size):
    """A chunk's declared uncompressed size is what a zstd frame without a content size is
    inflated into: 16 TiB failed the whole file as 'out of memory', and a 100 kB chunk of
    zeros honestly declaring 3 GiB took 3.2 GB and a minute. Beyond 256 MiB a chunk is taken
    as corrupt, at once; the rest of the file is read."""
    import resource
    import struct
    data = bytearray(base['chunks'].read_bytes())
    at = _chunk_spans(base['chunks'])[1][0] - 40       # the second chunk's header
    struct.pack_into('<Q', data, at + 16, size)        # its uncompressed size
    path = tmp_path / 'absurd.mcap'
    path.write_bytes(bytes(data))
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    for command in ('inspect', 'replay', 'recover'):
        lines = _check(capsys, command, path, tmp_path / command, 1, 'corrupt chunk')
        assert f'declares {size} bytes uncompressed, more than the 256 MiB a chunk may hold here' in lines[0], lines
    assert resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before < 200_000    # kB: nothing inflated


@pytest.mark.parametrize('fraction', [0.0, 0.001, 0.1, 0.37, 0.5, 0.81, 0.999])
def test_truncated_recordings(base, tmp_path, capsys, fraction):
    data = base['rec'].read_bytes()
    cut = int(len(data) * fraction)
    path = tmp_path / f'cut{cut}.mcap'
    path.write_bytes(data[:cut])
    for command in ('inspect', 'replay', 'recover'):
        lines = _check(capsys, command, path, tmp_path / command, None, None)
        if lines:
            assert str(path) in lines[0]


def test_cut_one_byte_short_is_analysed_and_says_so(base, tmp_path, capsys):
    """A recording cut inside its summary still holds every frame: analyze and report use
    them all, and, the file being damaged, say it and exit 1 like the others."""
    data = base['chunks'].read_bytes()
    path = tmp_path / 'short_by_one.mcap'
    path.write_bytes(data[:-1])
    for command in ('inspect', 'replay'):
        _check(capsys, command, path, tmp_path / command, None, None)


@pytest.mark.parametrize('suffix', ['.blf', '.asc'])
def test_cut_blf_and_asc_are_analysed_and_say_so(base, tmp_path, capsys, suffix):
    """A BLF or ASC log cut short: every command uses the frames before the cut and says the
    log breaks off (exit 1). The block readers once dropped a cut BLF's frames altogether."""

    from steer_monitor.logfiles.blocks import read_log_fast
    from steer_monitor.logfiles.logs import LogWriter
    from test.support.logwrite import write_asc
    frames = read_log_fast(base['long'])
    whole = tmp_path / f'whole{suffix}'
    if suffix == '.blf':
        with LogWriter(whole) as w:
            for f in frames.frames():
                w.write(f)
    else:
        write_asc(whole, frames)
    path = tmp_path / f'cut{suffix}'
    path.write_bytes(whole.read_bytes()[: whole.stat().st_size * 3 // 4])
    said = {}
    for command in LOG_COMMANDS:
        lines = _check(capsys, command, path, tmp_path / command, 1, 'log breaks off')
        assert str(path) in lines[0]
        said[command] = lines[0].removeprefix(f'steer-monitor {command}: error: ')
    assert len(set(said.values())) == 1
    out = json.loads((tmp_path / 'analyze' / 'a.json').read_text())
    assert 0.5 * len(frames) < out['data']['frames'] < len(frames)
    assert out['data']['read_errors'] == [said['analyze']]
    assert out['clearance_zgb_mm']['ci95'][0] is not None        # analysed: an estimate or a bound


@pytest.mark.parametrize('kind', ['gz', 'xz', 'zst'])
def test_a_compressed_log_cut_short_is_analysed_and_says_so(base, tmp_path, capsys, kind):
    """A rotated, compressed log whose copy was interrupted: every command uses the frames
    before the cut and names the log and the cut in one line (exit 1)."""
    import gzip
    import lzma

    import zstandard
    pack = {'gz': gzip.compress, 'xz': lzma.compress, 'zst': zstandard.ZstdCompressor().compress}[kind]
    whole = pack(base['long'].read_bytes())
    path = tmp_path / f'can0.log.1.{kind}'
    path.write_bytes(whole[: len(whole) * 3 // 4])
    said = {}
    for command in LOG_COMMANDS:
        lines = _check(capsys, command, path, tmp_path / command, 1, 'data cut short after')
        said[command] = lines[0].removeprefix(f'steer-monitor {command}: error: ')
        assert said[command].startswith(f'{path}: '), lines
    assert len(set(said.values())) == 1
    out = json.loads((tmp_path / 'analyze' / 'a.json').read_text())
    import zlib

    from steer_monitor.logfiles.compressed import PIECE_BYTES
    decoder = {'gz': lambda: zlib.decompressobj(31), 'xz': lzma.LZMADecompressor,
               'zst': lambda: zstandard.ZstdDecompressor().decompressobj()}[kind]()
    lines_in_reach = decoder.decompress(path.read_bytes()).count(b'\n')   # what the format gives up to the cut
    assert lines_in_reach - PIECE_BYTES // 40 <= out['data']['frames'] <= lines_in_reach
    assert out['clearance_zgb_mm']['ci95'][0] is not None        # analysed: an estimate or a bound


@pytest.mark.parametrize('damage', ['junk_after_magic', 'flipped'])
def test_a_damaged_compressed_log_is_one_line(base, tmp_path, capsys, damage):
    import gzip
    whole = gzip.compress(base['long'].read_bytes())
    data = b'\x1f\x8b' + random.Random(2).randbytes(4000) if damage == 'junk_after_magic' else \
        _flip(whole, 8, len(whole) // 2, len(whole), 4)
    path = tmp_path / 'x.log.gz'
    path.write_bytes(data)
    for command in LOG_COMMANDS:
        lines = _check(capsys, command, path, tmp_path / command, 1, None)
        assert f'{path}: gzip data' in lines[0], lines


@pytest.mark.parametrize('command', LOG_COMMANDS + ('recover',))
def test_unwritable_and_directory_outputs(base, tmp_path, capsys, command):
    src = base['rec'] if command == 'recover' else base['log']
    if command == 'inspect':
        return     # writes nothing
    # a file's directory that does not exist (report makes its directory, so: one under a file)
    (tmp_path / 'plain').write_text('x')
    bad_dir = tmp_path / 'plain' / 'dir' if command == 'report' else tmp_path / 'no' / 'such' / 'dir'
    rc, lines, _ = _run(capsys, _argv(command, src, bad_dir))
    assert rc == 1 and len(lines) == 1, lines
    if command == 'report':
        assert 'cannot create the output directory' in lines[0] and 'Not a directory' in lines[0], lines
    else:
        assert f'no directory {bad_dir}' in lines[0], lines
    # a directory where a file is wanted
    (tmp_path / 'isdir').mkdir()
    target = {'analyze': ['analyze', str(src), '--json', str(tmp_path / 'isdir')],
              'report': ['report', str(src), '--out', str(tmp_path / 'afile'), '--analysis-hours', '0'],
              'replay': ['replay', str(src), '--out', str(tmp_path / 'isdir')],
              'recover': ['recover', str(src), '--out', str(tmp_path / 'isdir')]}[command]
    if command == 'report':
        (tmp_path / 'afile').write_text('x')
    rc, lines, _ = _run(capsys, target)
    assert rc == 1 and len(lines) == 1, lines
    assert 'is a directory' in lines[0] or 'not a directory' in lines[0], lines
    _no_temporaries(tmp_path)



@pytest.mark.parametrize('command', LOG_COMMANDS)
@pytest.mark.parametrize('kind', ['directory', 'missing', 'name_too_long', 'broken_link', 'link_loop', 'device'])
def test_a_log_that_is_not_a_file_is_named_before_any_work(tmp_path, capsys, command, kind):
    log = tmp_path / ('s' * 300 + '.log' if kind == 'name_too_long' else 'adir.log')
    if kind == 'directory':
        log.mkdir()
    elif kind == 'broken_link':
        log.symlink_to(tmp_path / 'gone.log')
    elif kind == 'link_loop':
        log.symlink_to(tmp_path / 'other.log')
        (tmp_path / 'other.log').symlink_to(log)
    elif kind == 'device':
        log.symlink_to('/dev/zero')          # endless: read, it would never end
    out = tmp_path / 'out'
    out.mkdir()
    rc, lines, stdout = _run(capsys, _argv(command, log, out))
    want = {'directory': f'log {log} is a directory, not a file', 'missing': f'log {log} does not exist',
            'name_too_long': f'cannot open log {log}: File name too long',
            'broken_link': f'log {log} does not exist (a broken symbolic link)',
            'link_loop': f'cannot open log {log}: Too many levels of symbolic links',
            'device': f'log {log} is not a regular file'}[kind]
    assert rc == 1 and lines == [f'steer-monitor {command}: error: {want}'], lines
    assert stdout == '' and list(out.iterdir()) == []


def test_a_generous_max_duration_costs_nothing_and_a_cut_is_said(tmp_path, capsys):
    """The plant's histories grow with the programme: a cap of 10^12 s on a 71 s programme
    used to allocate for the cap (out of memory). A programme cut by the cap says so."""
    rc, lines, out = _run(capsys, ['simulate', '--program', 'hard_over_2', '--max-duration', '1e12',
                                   '--out', str(tmp_path / 'a.log')])
    assert rc == 0 and not lines and 'simulated hard_over_2 for 71.' in out and 'cut' not in out, (lines, out)
    rc, lines, out = _run(capsys, ['simulate', '--program', 'hard_over_2', '--max-duration', '30',
                                   '--out', str(tmp_path / 'b.log')])
    assert rc == 0 and 'simulated hard_over_2 for 30.0 s (cut at --max-duration 30 s):' in out, (lines, out)


@pytest.mark.parametrize('argv', [
    ['replay', '{log}', '--out', '{log}'],
    ['replay', '{log}', '--out', '{link}'],                     # the same file through a link
    ['analyze', '{log}', '--json', '{log}'],
    ['analyze', '{log}', '--report', '{tmp}/../{tmpname}/short.log'],
    ['discover', '{log}', '--write-config', '{log}'],
    ['discover', '{log}', '--config', '{cfg}', '--write-config', '{cfg}'],
    ['accuracy', '--config', '{cfg}', '--out', '{cfg}'],
    ['simulate', '--config', '{cfg}', '--out', '{cfglog}'],
    ['recover', '{log}', '--out', '{log}'],
    ['inspect', '{log}', '--config', '{cfg}', '--json', '{cfg}'],
])
def test_an_output_that_is_an_input_is_refused_and_the_input_kept(base, tmp_path, capsys, argv):
    """`replay X --out X` replaced the log with its replay, `discover X --write-config X` with
    a YAML file: the measurements lost. Refused before any work, naming both, unless --force."""
    import shutil
    log = tmp_path / 'short.log'
    shutil.copy(base['log'], log)
    (tmp_path / 'link.log').symlink_to(log)
    cfg = tmp_path / 'c.yaml'
    shutil.copy(PKG / 'config' / 'r18.yaml', cfg)
    shutil.copy(PKG / 'config' / 'nmea2000_steering.dbc', tmp_path)
    (tmp_path / 'c.log').symlink_to(cfg)                       # a parameters file a log's name leads to
    fill = {'log': str(log), 'link': str(tmp_path / 'link.log'), 'tmp': str(tmp_path), 'tmpname': tmp_path.name,
            'cfg': str(cfg), 'cfglog': str(tmp_path / 'c.log')}
    before = {p: p.read_bytes() for p in (log, cfg)}
    rc, lines, _ = _run(capsys, [a.format(**fill) for a in argv])
    assert rc == 1 and len(lines) == 1, lines
    assert re.fullmatch(rf'steer-monitor {argv[0]}: error: cannot write .*: it is the input '
                        rf'({re.escape(str(log))}|{re.escape(str(cfg))}); give another output, or --force to '
                        rf'replace it', lines[0]), lines
    assert {p: p.read_bytes() for p in before} == before


@pytest.mark.parametrize('argv', [
    ['discover', '{log}', '--write-config', '{packaged}'],     # no --config: the packaged file is the one in use
    ['loadshare', '--plot', '{packaged_png}'],                  # a link's target is what a write replaces
    ['simulate', '--out', '{packaged_log}'],
    ['fit', '240 H9/f9', '--json', '{packaged}'],               # every command that writes JSON to a file
])
def test_a_packaged_file_is_not_written_over_unasked(base, tmp_path, capsys, argv):
    """`discover LOG --write-config steer_monitor/config/r18.yaml` replaced the parameters every
    command and `ros2 run` read. A packaged file is refused as an output unless --force."""
    import shutil

    from steer_monitor.resources import config_dir
    log = tmp_path / 'short.log'
    shutil.copy(base['log'], log)
    packaged = config_dir() / 'r18.yaml'
    packaged_log = config_dir() / 'nmea2000_steering.dbc'      # any packaged file; the suffix only picks a format
    link = tmp_path / 'packaged.log'
    link.symlink_to(packaged_log)
    png = tmp_path / 'plot.png'
    png.symlink_to(packaged)
    fill = {'log': str(log), 'packaged': str(packaged), 'packaged_log': str(link), 'packaged_png': str(png)}
    before = {p: p.read_bytes() for p in (packaged, packaged_log)}
    rc, lines, _ = _run(capsys, [a.format(**fill) for a in argv])
    assert rc == 1 and len(lines) == 1, lines
    # the packaged parameters are also the input of a command given no --config: either reason is right
    assert re.fullmatch(rf'steer-monitor {argv[0]}: error: cannot write .*: it is (a file of the installed package '
                        rf'\(.*\)|the input {re.escape(str(packaged))}); give another output, or --force to '
                        rf'replace it', lines[0]), lines
    assert {p: p.read_bytes() for p in before} == before


def test_force_writes_over_an_input(base, tmp_path, capsys):
    """--force is the user saying so: discover's map written over the parameters file it read."""
    import shutil
    log = tmp_path / 'short.log'
    shutil.copy(base['log'], log)
    cfg = tmp_path / 'c.yaml'
    shutil.copy(PKG / 'config' / 'r18.yaml', cfg)
    shutil.copy(PKG / 'config' / 'nmea2000_steering.dbc', tmp_path)
    rc, lines, _ = _run(capsys, ['discover', str(log), '--config', str(cfg), '--write-config', str(cfg), '--force'])
    assert rc == 0 and not [ln for ln in lines if ': error:' in ln], lines
    from steer_monitor.params import load_params_file
    assert load_params_file(cfg)['can.dbc_file']


def test_recover_of_a_loop_of_links_is_one_line(tmp_path, capsys):
    (tmp_path / 'a.mcap').symlink_to(tmp_path / 'b.mcap')
    (tmp_path / 'b.mcap').symlink_to(tmp_path / 'a.mcap')
    rc, lines, _ = _run(capsys, _argv('recover', tmp_path / 'a.mcap', tmp_path))
    assert rc == 1 and lines == [f'steer-monitor recover: error: cannot open {tmp_path / "a.mcap"}: '
                                 'Too many levels of symbolic links'], lines


@pytest.mark.skipif(not Path('/proc/self').is_dir(), reason='needs Linux /proc (a directory no file can be made in)')
def test_simulate_names_the_output_it_was_given_not_its_temporary(tmp_path, capsys):
    """The log's writer cannot make its (temporary) file: the message names the output."""
    target = Path('/proc/steer_monitor_test.log')
    rc, lines, _ = _run(capsys, ['simulate', '--program', 'hard_over_2', '--max-duration', '2', '--out', str(target)])
    assert rc == 1 and len(lines) == 1, lines
    assert lines[0] == f'steer-monitor simulate: error: cannot write log {target}: No such file or directory', lines

BAD_YAML = {
    'non_utf8': (lambda cfg: cfg[:200] + b'\xff' + cfg[200:], 'is not UTF-8 text (byte 0xFF at offset 200)'),
    'nested': (lambda cfg: b'a: ' + b'[' * 5000, 'is nested too deeply to be a parameters file'),
    'alias_bomb': (lambda cfg: b'a: &a ["x","x","x","x","x","x","x","x","x"]\n'
                   + b''.join(f'{c}: &{c} [{",".join(["*" + p] * 9)}]\n'.encode()
                              for p, c in zip('abcdefgh', 'bcdefghi')), 'YAML aliases (*name) are not accepted'),
    'empty': (lambda cfg: b'', 'expected "steer_monitor: ros__parameters:" at the top'),
    'a_list': (lambda cfg: b'- 1\n- 2\n', 'expected "steer_monitor: ros__parameters:" at the top'),
    'junk': (lambda cfg: bytes(range(1, 128)) * 3, 'parameters file'),
    'huge': (lambda cfg: b'#' * (2 << 20), 'it cannot be a parameters file'),
}


@pytest.mark.parametrize('case', sorted(BAD_YAML))
@pytest.mark.parametrize('command', ['inspect', 'loadshare', 'simulate'])
def test_bad_parameters_files(base, tmp_path, capsys, case, command):
    make, phrase = BAD_YAML[case]
    cfg = tmp_path / f'{case}.yaml'
    cfg.write_bytes(make((PKG / 'config' / 'r18.yaml').read_bytes()))
    argv = {'inspect': ['inspect', str(base['log']), '--config', str(cfg)],
            'loadshare': ['loadshare', '--config', str(cfg)],
            'simulate': ['simulate', '--config', str(cfg), '--out', str(tmp_path / 's.log')]}[command]
    rc, lines, _ = _run(capsys, argv)
    assert rc == 1 and len(lines) == 1 and str(cfg) in lines[0] and phrase in lines[0], lines
    assert not (tmp_path / 's.log').exists()


def test_bad_chain_file(tmp_path, capsys):
    chain = tmp_path / 'chain.yaml'
    chain.write_bytes(b'chain: &c [*c]\n')
    rc, lines, _ = _run(capsys, ['backlash', str(chain)])
    assert rc == 1 and len(lines) == 1 and 'chain file' in lines[0], lines


@pytest.mark.parametrize('argv', [['inspect'], ['replay', 'x.log'], ['analyze', '--json', '-'], ['nonsense']])
def test_usage_errors_exit_2(capsys, argv):
    rc, lines, _ = _run(capsys, argv)
    assert rc == 2 and lines and not any('Traceback' in line for line in lines)


def test_missing_log(tmp_path, capsys):
    for command in LOG_COMMANDS:
        rc, lines, _ = _run(capsys, _argv(command, tmp_path / 'missing.log', tmp_path))
        assert rc == 1 and len(lines) == 1 and 'missing.log' in lines[0], (command, lines)


@pytest.mark.parametrize('bus', ['socketcan:can0', 'pcan:PCAN_USBBUS1', 'kvaser:0'])
def test_simulator_refuses_real_buses(capsys, bus):
    rc, lines, _ = _run(capsys, ['simulate', '--bus', bus, '--max-duration', '1'])
    assert rc == 1 and len(lines) == 1 and '--i-know-this-is-a-real-bus' in lines[0], lines


def test_clock_step_of_years_is_bounded_by_the_data(base, tmp_path, capsys):
    """A host clock stepped ten years ahead mid-log (and kept there): the step is confirmed,
    not rejected; analyze's grid, the node's analyses and replay's schedule follow the data,
    not the decade between (before: 47-57 GiB asked for, replay hung); the estimate is the
    one without the step, to the rows the cut takes."""
    lines = base['long'].read_bytes().splitlines(keepends=True)
    half = len(lines) // 2
    ten_years = 10 * 365 * 86400

    def later(line: bytes) -> bytes:
        sec, rest = line[1:].split(b'.', 1)
        return b'(' + str(int(sec) + ten_years).encode() + b'.' + rest
    path = tmp_path / 'stepped.log'
    path.write_bytes(b''.join(lines[:half]) + b''.join(later(x) for x in lines[half:]))
    got = {}
    for p in (base['long'], path):
        rc, lines_err, _ = _run(capsys, ['analyze', str(p), '--json', str(tmp_path / f'{p.stem}.json')])
        assert rc == 0, lines_err
        got[p] = json.loads((tmp_path / f'{p.stem}.json').read_text())
    a, b = got[base['long']], got[path]
    assert 'time_jump' not in b['data']['rejects']
    for key in ('clearance_2z_mm', 'clearance_zgb_mm'):
        assert b[key]['value'] == pytest.approx(a[key]['value'], abs=0.03), key
    rc, err, _ = _run(capsys, ['replay', str(path), '--out', str(tmp_path / 'r.mcap'), '--no-frames'])
    assert rc == 0, err


@pytest.mark.parametrize('argv,phrase', [
    (['analyze', '{log}', '--json', '{tmp}/no/dir/a.json'], 'cannot write {tmp}/no/dir/a.json: no directory'),
    (['analyze', '{log}', '--report', '{tmp}'], 'cannot write {tmp}: it is a directory'),
    (['accuracy', '--out', '{tmp}/no/dir/acc.md'], 'cannot write {tmp}/no/dir/acc.md: no directory'),
    (['study', '--out', '{log}/x'], 'cannot create the output directory {log}/x'),
    (['loadshare', '--plot', '{log}/x.png'], 'cannot write into {log}: it exists and is not a directory'),
    (['run', '--params-file', '{tmp}/missing.yaml'], 'cannot read parameters file {tmp}/missing.yaml'),
    (['fit', '240 Q9/f9'], 'only hole-basis fits'),
    (['loadshare', '--step-deg', '1e-9'], '--step-deg must lie in [0.001, 5], got 1e-09'),
    (['loadshare', '--plot', '{tmp}/fig.txt'], "cannot write {tmp}/fig.txt: matplotlib does not write '.txt' files; "
                                               'give the plot one of .avif'),
    (['loadshare', '--plot', '{tmp}/fig'], 'cannot write {tmp}/fig: no file type; give the plot one of'),
    (['simulate', '--max-duration', '0', '--out', '{tmp}/s.log'], '--max-duration must be more than 0 s, got 0.0'),
    (['simulate', '--seed', '-1', '--out', '{tmp}/s.log'], '--seed must be a whole number >= 0, got -1'),
    (['backlash', '{tmp}/missing.yaml'], 'cannot read chain file {tmp}/missing.yaml'),
    (['backlash', str(PKG / 'config' / 'r18_chain.yaml'), '--limit-arcmin', '-1'],
     '--limit-arcmin must be a positive number of arc minutes, got -1'),
    (['backlash', str(PKG / 'config' / 'r18_chain.yaml'), '--limit-arcmin', 'nan'],
     '--limit-arcmin must be a positive number of arc minutes, got nan'),
])
def test_the_other_subcommands_fail_in_one_line_before_their_work(base, tmp_path, capsys, argv, phrase):
    """Outputs are checked before minutes of work (analyze, accuracy), not after; the node's
    parameters file is read by us before rcl, which would print its own C error first."""
    fill = {'log': str(base['log']), 'tmp': str(tmp_path)}
    rc, lines, _ = _run(capsys, [a.format(**fill) for a in argv])
    assert rc == 1 and len(lines) == 1, lines
    assert phrase.format(**fill) in lines[0] and 'internal error' not in lines[0], lines


@pytest.mark.parametrize('argv, line', [
    (['analyze', '{tmp}/empty.log'], '{tmp}/empty.log holds no CAN frames: nothing to analyse'),
    (['simulate', '--max-duration', '2', '--out', '{tmp}/x.csv'],
     "--out {tmp}/x.csv: simulate writes a log ending in .log (candump), .blf or .mcap, not '.csv'"),
])
def test_messages_say_what_the_user_gave_and_no_temporary_name(tmp_path, capsys, argv, line):
    (tmp_path / 'empty.log').write_text('')
    assert main([a.replace('{tmp}', str(tmp_path)) for a in argv]) == 1
    err = capsys.readouterr().err
    assert err == f"steer-monitor {argv[0]}: error: {line.replace('{tmp}', str(tmp_path))}\n"
    assert '.tmp' not in err
    assert not (tmp_path / 'x.csv').exists()


def test_a_failed_report_leaves_no_output_directory(tmp_path, capsys):
    """A report of a log without a frame once left an empty directory that passed for a result."""
    bad = tmp_path / 'bad.log'
    bad.write_text('garbage\n')
    assert main(['report', str(bad), '--out', str(tmp_path / 'out' / 'report')]) == 1
    assert capsys.readouterr().err == f'steer-monitor report: error: no frame in {bad}\n'
    assert not (tmp_path / 'out').exists()


def test_a_log_without_steering_frames_is_refused_by_every_command(tmp_path, capsys):
    """Only the speed log and the oil temperature: inspect shows what the log holds and, as
    analyze, replay and report, refuses it in analyze's words with a non-zero exit; no output
    is left."""
    from steer_monitor.cli import simulate
    full = tmp_path / 'full.log'
    simulate.run(None, 'hold:20', full, seed=2, out=io.StringIO())
    path = tmp_path / 'nosteer.log'
    kept = [ln for ln in full.read_text().splitlines() if ' 09F50330#' in ln or ' 15FD0C40#' in ln]
    path.write_text(''.join(ln + '\n' for ln in kept))
    why = f'{path}: no rudder angle in the data (input rudder_angle): nothing to estimate from'
    for argv, out in ((['inspect', str(path)], None), (['analyze', str(path)], None),
                      (['replay', str(path), '--out', str(tmp_path / 'r.mcap')], tmp_path / 'r.mcap'),
                      (['report', str(path), '--out', str(tmp_path / 'page')], tmp_path / 'page')):
        assert main(argv) == 1, argv
        err = capsys.readouterr().err
        assert err.strip().endswith(why.split(': ', 1)[1]) and 'Traceback' not in err, (argv, err)
        assert out is None or not out.exists(), argv
