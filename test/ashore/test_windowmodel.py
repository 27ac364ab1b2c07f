"""What the report's windows fit to follow a model check (the refit itself: test_review)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from steer_monitor.ashore.windowmodel import Nuisance, window_model
from steer_monitor.estimate.effects import Effect


def test_the_adopted_effects_and_no_nuisance_where_the_check_explained_the_data():
    viscous = (Effect('viscous'),)
    assert window_model(SimpleNamespace(verdict='effect', adopted=viscous)) == (viscous, None)
    assert window_model(SimpleNamespace(verdict='declared', adopted=())) == ((), None)


def test_an_unexplained_residual_without_a_located_term_widens_the_intervals_only():
    """No term located: no piece to fit, the misfit counted as noise ((noise² + systematic²) /
    noise² of the model's residual)."""
    model = SimpleNamespace(noise_rms=2.0, smooth_rms=1.0)
    effects, nuisance = window_model(SimpleNamespace(verdict='unexplained', adopted=(), located=None, model=model))
    assert effects == () and nuisance == Nuisance(None, (), pytest.approx(1.25))
