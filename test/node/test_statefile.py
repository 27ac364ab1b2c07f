"""The analyses' state file: where it lives, and a failure to save told once until it saves again."""

from __future__ import annotations

from steer_monitor.monitor.pipeline import analyst_from_params
from steer_monitor.node.statefile import StateFile
from steer_monitor.params import gear_from_params


def test_a_relative_name_lives_in_the_recording_directory(tmp_path):
    f = StateFile.from_params('estimator.npz', str(tmp_path / 'rec'), print, print)
    assert f.path == tmp_path / 'rec' / 'estimator.npz'
    assert StateFile.from_params('', str(tmp_path), print, print).path is None


def test_a_failure_to_save_is_told_once_and_its_end_too(tmp_path, r18_params):
    analyst = analyst_from_params(gear_from_params(r18_params), r18_params)
    blocker = tmp_path / 'not_a_directory'
    blocker.write_text('')
    errors, infos = [], []
    f = StateFile(blocker / 'state.npz', errors.append, infos.append)
    for _ in range(3):
        f.save(analyst, 0.0)
    assert len(errors) == 1 and errors[0].startswith("cannot save the analyses' state: ") and f.error == errors[0]
    blocker.unlink()
    blocker.mkdir()
    f.save(analyst, 12.0)
    assert f.error is None and infos == [f"analyses' state saved to {blocker / 'state.npz'} again"]
    assert (blocker / 'state.npz').exists()
