"""Matplotlib figures (Agg backend, PNG files). Inputs are SI; axes are in engineers' units."""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from steer_monitor.atomic import atomic_path, ensure_dir
from steer_monitor.errors import OutputError
from steer_monitor.model.landmarks import GapSensitivity, Landmarks
from steer_monitor.model.loadshare import LoadSharing

__all__ = ['gap_sensitivity_png', 'load_sharing_png', 'plot_gap_sensitivity', 'plot_load_sharing']


def _pyplot():
    import matplotlib
    matplotlib.use('Agg')
    import matplotlib.pyplot as plt
    return plt


def plot_load_sharing(alpha: NDArray[np.float64], res: LoadSharing, path: str | Path,
                      title: str, marks: Landmarks | None = None) -> Path:
    """The paper's Fig. 7 written to ``path`` in the format its suffix names."""
    plt = _pyplot()
    return _save(plt, _load_sharing_figure(plt, alpha, res, title, marks), path)


def load_sharing_png(alpha: NDArray[np.float64], res: LoadSharing, title: str,
                     marks: Landmarks | None = None) -> bytes:
    """The paper's Fig. 7 as PNG bytes (for outputs written together, :func:`~steer_monitor.atomic.write_files`)."""
    plt = _pyplot()
    return _png(plt, _load_sharing_figure(plt, alpha, res, title, marks))


def _load_sharing_figure(plt: Any, alpha: NDArray[np.float64], res: LoadSharing, title: str,
                         marks: Landmarks | None) -> Any:
    """The paper's Fig. 7: (a) F_r and F_gb against rudder angle, (b) K_gl against angle."""
    deg = np.degrees(alpha)
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 4.2), constrained_layout=True)
    ax1.plot(deg, res.lateral / 1e3, color='0.6', ls='--', label='$F_l$ lateral')
    ax1.plot(deg, res.ram_force / 1e3, color='tab:red', label='$F_r$ ram')
    ax1.plot(deg, res.guide_force / 1e3, color='tab:blue', label='$F_{gb}$ guide beam')
    if marks is not None and marks.crossover is not None:
        xc = np.degrees(marks.crossover)
        yc = float(np.interp(xc, deg, res.ram_force / 1e3))
        ax1.plot([xc], [yc], 'ko')
        ax1.annotate(f'$F_r = F_{{gb}}$ at {xc:.1f} deg', (xc, yc), xytext=(6, -14),
                     textcoords='offset points')
    ax1.set_xlabel('rudder angle alpha [deg]')
    ax1.set_ylabel('lateral force on one ram [kN]')
    ax1.set_title('(a) load on ram and guide beam')
    ax1.grid(True, alpha=0.3)
    ax1.legend(loc='upper left')
    ax2.plot(deg, res.k_gl, color='tab:green')
    if marks is not None:
        ax2.plot([np.degrees(marks.k_gl_max_angle)], [marks.k_gl_max], 'ko')
        ax2.annotate(f'max {marks.k_gl_max:.2f} at {np.degrees(marks.k_gl_max_angle):.1f} deg',
                     (np.degrees(marks.k_gl_max_angle), marks.k_gl_max), xytext=(-90, -18),
                     textcoords='offset points')
    ax2.set_xlabel('rudder angle alpha [deg]')
    ax2.set_ylabel('$K_{gl} = F_{gb} / F_l$')
    ax2.set_ylim(0, 1)
    ax2.set_title('(b) guide-beam load coefficient')
    ax2.grid(True, alpha=0.3)
    fig.suptitle(title)
    return fig


def _png(plt: Any, fig: Any) -> bytes:
    """``fig`` as PNG bytes, at the resolution :func:`_save` writes; closed."""
    try:
        buf = io.BytesIO()
        fig.savefig(buf, dpi=110, format='png')
        return buf.getvalue()
    finally:
        plt.close(fig)


def _save(plt: Any, fig: Any, path: str | Path) -> Path:
    """Write ``fig`` to ``path`` (its directory made, the file whole or not at all) in the
    format its suffix names; close it. :class:`OutputError` for a suffix matplotlib does not
    write (or none)."""
    path = Path(path)
    try:
        kinds = fig.canvas.get_supported_filetypes()
        fmt = path.suffix[1:].lower()
        if fmt not in kinds:
            msg = (f'cannot write {path}: ' + (f"matplotlib does not write '.{fmt}' files" if fmt else 'no file type')
                   + f"; give the plot one of {', '.join('.' + k for k in sorted(kinds))}")
            raise OutputError(msg)
        ensure_dir(path.parent)
        with atomic_path(path) as tmp:
            fig.savefig(tmp, dpi=110, format=fmt)
    finally:
        plt.close(fig)
    return path


def plot_gap_sensitivity(study: GapSensitivity, path: str | Path, title: str) -> Path:
    """Peak K_gl against 2Z written to ``path`` in the format its suffix names."""
    plt = _pyplot()
    return _save(plt, _gap_sensitivity_figure(plt, study, title), path)


def gap_sensitivity_png(study: GapSensitivity, title: str) -> bytes:
    """Peak K_gl against 2Z as PNG bytes."""
    plt = _pyplot()
    return _png(plt, _gap_sensitivity_figure(plt, study, title))


def _gap_sensitivity_figure(plt: Any, study: GapSensitivity, title: str) -> Any:
    """Peak K_gl against 2Z, one line per Z_gb."""
    fig, ax = plt.subplots(figsize=(7, 4.2), constrained_layout=True)
    for j, z in enumerate(study.z_gb):
        ax.plot(study.two_z * 1e3, study.k_gl_max[:, j], marker='o', ms=3,
                label=f'$Z_{{gb}}$ = {z * 1e3:.2f} mm')
    ax.set_xlabel('ram / bushing clearance 2Z [mm]')
    ax.set_ylabel('peak $K_{gl}$ over 0..35 deg')
    ax.set_ylim(0, 1)
    ax.grid(True, alpha=0.3)
    ax.legend()
    ax.set_title(title)
    return fig
