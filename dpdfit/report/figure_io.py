"""Access to matplotlib and PNG writing shared by every figure module of ``dpdfit.report``.

matplotlib is imported on first use only (``dpdfit`` itself never needs it),
always on the non-interactive Agg backend; figures are written as PNG at 130
dpi into a staging area (:func:`dpdfit.recordings.outputs.staged_outputs`) so
that a set of figures appears together or not at all.
"""

from __future__ import annotations

import os

__all__ = ["pyplot", "save_png", "DPI"]

#: resolution of every PNG figure
DPI = 130


def pyplot():
    """``matplotlib.pyplot`` on the Agg backend (imported here, on first use)."""
    import matplotlib
    matplotlib.use("Agg", force=True)
    import matplotlib.pyplot as plt
    return plt


def save_png(fig, stage, outdir: str | os.PathLike, name: str) -> str:
    """Write ``fig`` as ``outdir/name`` through ``stage`` and close it; returns the path."""
    import matplotlib.pyplot as plt
    path = os.path.join(outdir, name)
    fig.savefig(stage(path), dpi=DPI, format="png")
    plt.close(fig)
    return path
