"""The README against the program: every command and option its synopsis names exists, and
every file its examples name is where a user running them from the root finds it."""

from __future__ import annotations

import argparse
import re

import pytest

from steer_monitor.cli.main import build_parser
from test.conftest import PKG

README = (PKG / 'README.md').read_text(encoding='utf-8')


def _synopsis() -> list[str]:
    """The lines of the Command line section's first code block, continuations joined."""
    section = README[README.index('## Command line'):]
    block = section[section.index('```sh\n') + 6:]
    block = block[:block.index('```')]
    return [' '.join(line.split()) for line in block.replace('\\\n', ' ').splitlines() if line.strip()]


def _subparsers() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    action = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    return dict(action.choices)


def test_the_synopsis_names_every_command():
    named = [line.split()[1] for line in _synopsis()]
    assert sorted(set(named)) == sorted(_subparsers()), named


@pytest.mark.parametrize('line', _synopsis(), ids=lambda line: line.split()[1])
def test_every_option_in_the_synopsis_exists(line):
    command = line.split()[1]
    code = line.split('#')[0].split(' -- ')[0]          # after --: ROS arguments, not ours
    sub = _subparsers()[command]
    known = {s for a in sub._actions for s in a.option_strings}
    named = set(re.findall(r'(?<![\w-])(--[a-z][a-z0-9-]*)', code))
    assert named <= known, f'{command}: {sorted(named - known)} not among {sorted(known)}'


@pytest.mark.parametrize('line', _synopsis(), ids=lambda line: line.split()[1])
def test_every_packaged_file_an_example_names_exists_from_the_root(line):
    for path in re.findall(r'(config/[\w./-]+)', line):
        assert (PKG / path).is_file(), f'{path} (named in: {line})'


def test_what_the_readme_says_of_json_holds():
    """The README says which commands take --json; each of those has it, and the others do not."""
    subs = _subparsers()
    with_json = sorted(n for n, p in subs.items() if any('--json' in a.option_strings for a in p._actions))
    m = re.search(r'`--json` \(its vocabulary.*?\)\) on ([^(]*) \(', README[README.index('## Command line'):])
    assert m is not None, 'the README says which commands take --json'
    said = sorted(re.findall(r'`(\w+)`', m.group(1)))
    assert said == with_json, (said, with_json)


def test_the_synopsis_is_complete():
    """Every option of every command is in the synopsis (it omitted a dozen)."""
    named: dict[str, set[str]] = {}
    for line in _synopsis():
        named.setdefault(line.split()[1], set()).update(
            re.findall(r'(?<![\w-])(--[a-z][a-z0-9-]*)', line.split('#')[0]))
    for command, sub in _subparsers().items():
        options = {s for a in sub._actions for s in a.option_strings if s.startswith('--') and s != '--help'}
        assert options <= named.get(command, set()), f'{command}: {sorted(options - named.get(command, set()))}'


def test_every_section_the_readme_points_to_exists():
    """"see *Recording*" pointed to a section that had moved to docs/."""
    headings = [h.strip('# ').strip() for h in README.splitlines() if h.startswith('#')]
    for name in re.findall(r'see \*([^*]+)\*', README):
        assert any(h.startswith(name) or name in h for h in headings), name


def test_above_and_below_point_the_right_way():
    """"see *Ashore* below" pointed down to a section that is above it."""
    lines = README.splitlines()
    where = {h.strip('# ').strip(): i for i, h in enumerate(lines) if h.startswith('#')}
    for i, line in enumerate(lines):
        for name, direction in re.findall(r'see \*([^*]+)\* (above|below)', line):
            at = next(j for h, j in where.items() if h.startswith(name) or name in h)
            assert (at < i) == (direction == 'above'), (name, direction, i + 1)


@pytest.mark.slow
def test_the_simulated_fleet_example_runs_as_written(tmp_path):
    """The README's small fleet from simulated logs, run by a shell as a user would paste it:
    six logs two months apart, and the trend finds the wear it was given (0.12 mm/year)."""
    import os
    import shutil
    import subprocess
    import sys
    block = README[README.index('mkdir -p vessels/mv_sim'):]
    block = block[:block.index('```')]
    env = dict(os.environ, PATH=f'{os.path.dirname(sys.executable)}{os.pathsep}{os.environ.get("PATH", "")}',
               ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    assert shutil.which('steer-monitor', path=env['PATH']) is not None
    done = subprocess.run(['bash', '-e', '-c', block], cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=900, check=False)
    assert done.returncode == 0, done.stderr[-2000:]
    line = next(ln for ln in done.stdout.splitlines() if ln.strip().startswith('Z_gb: '))
    rate = re.search(r'wearing at ([\d.]+) \[([\d.]+) \.\. ([\d.]+)\] mm/year', line)
    assert rate is not None, line
    assert float(rate.group(2)) <= 0.12 <= float(rate.group(3)), line
    assert (tmp_path / 'fleet_sim' / 'index.html').is_file()


def _shell(block: str, cwd, timeout: float = 900):
    """Run a README block with bash -e in ``cwd``, the venv's steer-monitor on PATH and
    ``config`` reachable as from the repository's root."""
    import os
    import subprocess
    import sys
    env = dict(os.environ, PATH=f'{os.path.dirname(sys.executable)}{os.pathsep}{os.environ.get("PATH", "")}',
               ROS_AUTOMATIC_DISCOVERY_RANGE='LOCALHOST')
    if not (cwd / 'config').exists():
        (cwd / 'config').symlink_to(PKG / 'config')
    return subprocess.run(['bash', '-e', '-c', block], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=timeout, check=False)


def _block_from(start: str) -> str:
    block = README[README.index(start):]
    return block[:block.index('```')]


#: what a synopsis line's placeholders stand for when it is run as written
PLACEHOLDERS = {'LOG...': 'voyage.log', 'LOG_OR_MCAP...': 'voyage.log', 'OUT.mcap': 'replayed.mcap',
                'DIR': 'out_dir', 'VESSEL_DIR...': 'vessels/mv_alpha', 'FILE.mcap': 'replayed.mcap'}
#: synopsis lines not run, and why
NOT_RUN = {'run': 'the node: it runs until stopped (test/node starts it)',
           'demo': 'make demo, 70 s in real time (CI runs it)',
           'accuracy': 'a study of minutes (its test runs a small one)'}


@pytest.mark.slow
def test_the_readme_examples_run_as_written(tmp_path):
    """Every command line of the README run by a shell as written (the synopsis with its
    optional parts left out and its placeholders given files): the ashore examples on two
    recordings and two vessels' directories, then each synopsis line in order."""
    prep = ('steer-monitor simulate --program hard_over_2 --max-duration 60 --seed 3 --out day1.mcap\n'
            'steer-monitor simulate --program zigzag_10 --max-duration 60 --seed 4 --start 2026-01-02T08:00:00Z '
            '--out day2.mcap\n'
            'mkdir -p vessels/mv_alpha vessels/mv_beta\n'
            'steer-monitor simulate --program realistic:300 --seed 5 --out vessels/mv_alpha/a.log\n'
            'steer-monitor simulate --program realistic:300 --seed 6 --out vessels/mv_beta/b.log\n')
    done = _shell(prep, tmp_path)
    assert done.returncode == 0, done.stderr[-2000:]
    ashore = _block_from('steer-monitor replay day1.mcap day2.mcap')
    done = _shell(ashore, tmp_path)
    assert done.returncode == 0, (ashore, done.stderr[-2000:])
    assert (tmp_path / 'replayed.mcap').is_file() and (tmp_path / 'report' / 'index.html').is_file()
    assert (tmp_path / 'out.json').is_file() and (tmp_path / 'out.html').is_file()
    fleet = _block_from('steer-monitor fleet vessels/mv_alpha')
    for variant in (re.sub(r'\s*\[[^\]]*\]', '', fleet), fleet.replace('[--workers 4 | --scheduler tcp://host:8786]',
                                                                          '--workers 2 --force')):
        done = _shell(variant, tmp_path)
        assert done.returncode == 0, (variant, done.stderr[-2000:])
        assert (tmp_path / 'fleet' / 'index.html').is_file()
    ran = []
    for line in _synopsis():
        command = line.split()[1]
        if command in NOT_RUN or '--bus' in line:
            continue
        code = re.sub(r'\s*\[[^\]]*\]', '', line.split(' # ')[0])
        for name, value in PLACEHOLDERS.items():
            code = re.sub(rf'(?<![\w/.-]){re.escape(name)}(?![\w/.-])', value, code)
        if command == 'discover':
            code = 'cp voyage.log bus.log && ' + code
        done = _shell(code, tmp_path)
        assert done.returncode == 0, (code, done.stderr[-2000:])
        ran.append(command)
    assert sorted(set(ran) | set(NOT_RUN)) == sorted(_subparsers()), ran


#: a status line of the demo: [time] LEVEL name: message
DEMO_STATUS = re.compile(r'^\[\s*([\d.]+) s\] (OK|WARN|ERROR|STALE)\s+([\w ]+): (.*)$')


def _demo_pattern(message: str) -> re.Pattern[str]:
    """A README demo message as a pattern: each number stands for any number, a trailing or
    inner '...' for anything (the README shortens)."""
    parts = re.split(r'(\.\.\.|-?\d+(?:\.\d+)?)', message)
    out = ''
    for part in parts:
        if part == '...':
            out += '.*'
        elif re.fullmatch(r'-?\d+(?:\.\d+)?', part or 'x'):
            out += r'-?\d+(?:\.\d+)?'
        else:
            out += re.escape(part)
    return re.compile(out)


@pytest.mark.slow
def test_the_readme_demo_lines_are_what_the_demo_prints(tmp_path):
    """Each status line the README shows of ``make demo`` is one the demo prints: the same level,
    the same status and the same words (numbers as any number, '...' as what the README leaves
    out), in the same order."""
    import io
    import os

    from steer_monitor.cli import demo
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    listing = README[README.index('== steer_monitor demo'):]
    listing = listing[:listing.index('```')]
    shown = [m.groups() for m in map(DEMO_STATUS.match, listing.splitlines()) if m]
    assert len(shown) >= 5
    out = io.StringIO()
    assert demo.run(tmp_path / 'out', out=out) == 0
    printed = [m.groups()[1:] for m in map(DEMO_STATUS.match, out.getvalue().splitlines()) if m]
    # the lines the README shows at one time may come in any order among themselves (on a loaded
    # machine the first diagnostics can come before every input is heard, and their line again later)
    at = group = 0
    last_time = None
    for when, level, name, message in shown:
        if when != last_time:
            group, last_time = at, when
        pattern = _demo_pattern(message)
        found = next((k for k in range(group, len(printed)) if printed[k][:2] == (level, name)
                      and pattern.fullmatch(printed[k][2])), None)
        assert found is not None, (level, name, message, printed[group:])
        at = max(at, found + 1)
