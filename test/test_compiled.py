"""numba is optional: without it the compiled loops run interpreted, with the same answers, and
the node and the commands that wait on them say so."""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

from steer_monitor import compiled
from test.conftest import ROOT
from test.support import compiledprobe

#: the same IEEE operations in the same order (numba compiles without fast-math, so nothing is
#: fused or reassociated): equal to rounding; a few ulps allowed for libm's last bit
RTOL = 1e-13


def _hidden(code: str) -> subprocess.CompletedProcess[str]:
    prelude = "import sys; sys.modules['numba'] = None\n"
    return subprocess.run([sys.executable, '-c', prelude + code], capture_output=True, text=True, cwd=ROOT,
                          timeout=120, check=False)


def test_numba_is_used_where_installed():
    import numba

    from steer_monitor.model import loadshare
    assert compiled.COMPILED and compiled.interpreted_note() is None
    assert isinstance(loadshare._solve, numba.core.registry.CPUDispatcher)


def test_without_numba_every_compiled_loop_gives_the_same_answers(tmp_path):
    out = tmp_path / 'interpreted.npz'
    p = subprocess.run([sys.executable, '-m', 'test.support.compiledprobe', str(out)], capture_output=True, text=True,
                       cwd=ROOT, timeout=300, check=False)
    assert p.returncode == 0, p.stderr
    interpreted = dict(np.load(out))
    here = compiledprobe.results()
    assert set(interpreted) == set(here)
    for name, value in here.items():
        assert value.size > 0, name
        np.testing.assert_allclose(interpreted[name], value, rtol=RTOL, atol=0.0, equal_nan=True, err_msg=name)


def test_without_numba_the_package_says_so_and_loads_nothing_compiled():
    p = _hidden('from steer_monitor import compiled\n'
                'f = lambda x: x + 1\n'
                'assert compiled.njit(cache=True, nogil=True)(f) is f\n'
                'print(compiled.COMPILED)\n'
                'print(compiled.interpreted_note())\n')
    assert p.returncode == 0, p.stderr
    flag, note = p.stdout.splitlines()
    assert flag == 'False'
    assert note.startswith('numba is not installed: the model and the estimator run interpreted, with the same answers')
    assert 'python3-numba' in note


@pytest.mark.parametrize(('command', 'said'), [('loadshare', True), ('fit', False)])
def test_a_command_that_runs_the_model_says_it_runs_interpreted(command, said):
    """The note on stderr, once, before the command's own output; a command that never runs a
    compiled loop says nothing of it."""
    args = {'loadshare': "['loadshare', '--step-deg', '5']", 'fit': "['fit', '250H7/f7']"}[command]
    p = _hidden(f'from steer_monitor.cli.main import main\nraise SystemExit(main({args}))\n')
    assert p.returncode == 0, p.stderr
    notes = [line for line in p.stderr.splitlines() if 'numba is not installed' in line]
    assert notes == ([f'steer-monitor {command}: note: {compiled.INTERPRETED}'] if said else [])


def _without_timing(doc: object) -> object:
    """The document less the seconds the analysis took (the one thing that differs)."""
    if isinstance(doc, dict):
        return {k: _without_timing(v) for k, v in doc.items() if k != 'analysis_s'}
    if isinstance(doc, list):
        return [_without_timing(v) for v in doc]
    return doc


@pytest.mark.slow
def test_an_analysis_interpreted_gives_the_same_finding(tmp_path):
    """A minute of hard-overs (seed 9102, used for nothing else) analysed with numba and without:
    the same document, to the last digit printed, and the interpreted run said it was one."""
    import json

    from steer_monitor.cli.main import main
    log = tmp_path / 'h.log'
    assert main(['simulate', '--program', 'hard_over_2', '--out', str(log), '--seed', '9102']) == 0
    assert main(['analyze', str(log), '--json', str(tmp_path / 'numba.json')]) == 0
    p = _hidden(f"from steer_monitor.cli.main import main\n"
                f"raise SystemExit(main(['analyze', {str(log)!r}, '--json', {str(tmp_path / 'plain.json')!r}]))\n")
    assert p.returncode == 0, p.stderr
    assert f'steer-monitor analyze: note: {compiled.INTERPRETED}' in p.stderr.splitlines()
    here, plain = (json.loads((tmp_path / f'{n}.json').read_text()) for n in ('numba', 'plain'))
    assert 'analysis_s' in json.dumps(here)
    assert _without_timing(plain) == _without_timing(here)
