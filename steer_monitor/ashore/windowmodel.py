"""What the report's windows fit to follow a model check of the log. Pure.

The page's clearances are the model check's (``analyze`` of the log's last hours): the declared
model with the effects it adopted and, where it left a residual it could not name, the term it
located taken out as a nuisance. The review's windows (the plot of the clearances over time)
are refitted under the same model (:func:`~steer_monitor.ashore.reviewlogs.refit_windows`); this
says what that model is.
"""

from __future__ import annotations

from dataclasses import dataclass

from steer_monitor.estimate.analyze import Analysis, unexplained_inflation
from steer_monitor.estimate.effects import Effect
from steer_monitor.estimate.locate import Located

__all__ = ['Nuisance', 'window_model']


@dataclass(frozen=True)
class Nuisance:
    """Where a model check left the residual unexplained, what its clearances were fitted with:
    the term it located (None: none found) and the pieces of it the fit kept (a free level
    each, :meth:`~steer_monitor.estimate.locate.Located.columns`), and the factor its intervals
    count the misfit with (:func:`~steer_monitor.estimate.analyze.unexplained_inflation`)."""

    located: Located | None
    pieces: tuple[str, ...]
    model_inflation: float


def window_model(analysis: Analysis) -> tuple[tuple[Effect, ...], Nuisance | None]:
    """What the windows fit to follow the model check ``analysis``: the effects it adopted and,
    where it left a residual unexplained, the nuisance its clearances were fitted with."""
    if analysis.verdict != 'unexplained':
        return analysis.adopted, None
    located, pieces = analysis.located, ()
    if located is not None:
        pieces = tuple(c.name for c in located.columns(analysis.final_observations)[1])
    return analysis.adopted, Nuisance(located if pieces else None, pieces, unexplained_inflation(analysis.model))
