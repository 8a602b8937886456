"""Corner plot of the amplitude-calibration posterior (:mod:`dpdfit.fits.posterior`)."""

from __future__ import annotations

import numpy as np

from dpdfit.errors import InputError
from dpdfit.fits.posterior import PosteriorResult

__all__ = ["plot_corner"]


def plot_corner(result: PosteriorResult, path, params=None, bins: int = 40,
                max_points: int = 4000) -> str:
    """Corner plot (matplotlib only) of ``A_corr`` and selected ``a_k``.

    ``params`` lists names among ``"A_corr"`` and ``"a2".."aK"`` (default:
    ``A_corr, a2, a3, a4``).  Diagonal: histograms with the median and 68 %
    interval; off-diagonal: scatter of up to ``max_points`` draws.
    """
    import matplotlib
    matplotlib.use("Agg", force=False)
    import matplotlib.pyplot as plt
    cols = {"A_corr": np.asarray(result.A_corr_draws)}
    for i, p in enumerate(result.powers):
        if p > 1:
            cols[f"a{p}"] = np.asarray(result.a_draws)[:, i]
    params = list(params or ["A_corr"] + [f"a{p}" for p in result.powers[1:4]])
    for p in params:
        if p not in cols:
            raise InputError(f"unknown corner-plot parameter {p!r}; choose from {list(cols)}")
    X = np.column_stack([cols[p] for p in params])
    rng = np.random.default_rng(0)
    sel = rng.choice(X.shape[0], size=min(max_points, X.shape[0]), replace=False)
    k = len(params)
    fig, axes = plt.subplots(k, k, figsize=(2.2 * k, 2.2 * k), squeeze=False)
    for i in range(k):
        for j in range(k):
            ax = axes[i, j]
            if j > i:
                ax.set_visible(False)
                continue
            if i == j:
                ax.hist(X[:, i], bins=bins, histtype="step", color="k")
                for q, ls in ((0.5, "-"), (0.16, "--"), (0.84, "--")):
                    ax.axvline(np.quantile(X[:, i], q), color="C0", ls=ls, lw=0.8)
                ax.set_yticks([])
            else:
                ax.plot(X[sel, j], X[sel, i], ",", color="k", alpha=0.5)
            if i == k - 1:
                ax.set_xlabel(params[j])
            else:
                ax.set_xticklabels([])
            if j == 0 and i > 0:
                ax.set_ylabel(params[i])
            elif j > 0:
                ax.set_yticklabels([])
    fig.suptitle(f"posterior, tau {result.tau_max:.1f}, {result.n_independent:.0f} indep.")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return str(path)
