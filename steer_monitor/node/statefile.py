"""Where the node keeps its analyses' state across restarts, and saving it. Pure of ROS.

The state (the window of samples, the schedule, the last finding: :meth:`Analyst.save`) lives
in ``estimator.state_file``; a relative name in the recording directory, not wherever the node
was started from. Its directory is made once: made again later, a directory on a disk since
unmounted would be made on the disk beneath its mount point (the recorder refuses that too). A
failure to save is told once, until a save succeeds again.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

from steer_monitor.atomic import ensure_dir
from steer_monitor.errors import OutputError
from steer_monitor.monitor.analyst import Analyst

__all__ = ['StateFile']


class StateFile:
    """The analyses' state file ``path`` (None: not kept); ``tell_error`` and ``tell_info``
    hear what the log should say (once per failure, and when saving works again)."""

    def __init__(self, path: Path | None, tell_error: Callable[[str], None], tell_info: Callable[[str], None]) -> None:
        self.path = path
        self._tell_error, self._tell_info = tell_error, tell_info
        #: the last save's failure, until a save succeeds (None: saved, or not tried)
        self.error: str | None = None
        self._dir_made = False

    @classmethod
    def from_params(cls, name: str, recording_directory: str, tell_error: Callable[[str], None],
                    tell_info: Callable[[str], None]) -> StateFile:
        """``estimator.state_file`` (empty: not kept; relative: in the recording directory)."""
        return cls(Path(recording_directory, name) if name else None, tell_error, tell_info)

    def save(self, analyst: Analyst, motion_s: float) -> None:
        """The analyst's state saved, with the rudder motion counted [s]."""
        path = self.path
        if path is None:
            return
        try:
            if not self._dir_made:
                ensure_dir(path.parent)
                self._dir_made = True
            analyst.save(path, motion_s)
        except OutputError as exc:
            text = f'cannot save the analyses\' state: {exc}'
            if text != self.error:       # once, not at every save while it lasts
                self._tell_error(text)
            self.error = text
            return
        if self.error is not None:
            self.error = None
            self._tell_info(f'analyses\' state saved to {path} again')
