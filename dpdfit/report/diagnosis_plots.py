"""Before/after residual figures of the discrepancy diagnosis (``dpdfit diagnose --plot``)."""

from __future__ import annotations

from pathlib import Path

from dpdfit.analyses.diagnosis.result import Diagnosis
from dpdfit.recordings.outputs import staged_outputs
from dpdfit.report.figure_io import pyplot

__all__ = ["plot_diagnosis", "DIAGNOSIS_DPI"]

#: resolution of the diagnosis figures
DIAGNOSIS_DPI = 110


def plot_diagnosis(result: Diagnosis, folder, outdir) -> list[str]:
    """Before/after standardised residuals of every series, one figure per observable kind.

    Writes ``diagnosis_tones.png``, ``diagnosis_gates.png`` (and time scans)
    into ``outdir``: baseline residuals (grey) and residuals under the chosen
    effect (colour), with the located intervals shaded.  Returns the paths.
    """
    plt = pyplot()
    before = {(s[0], s[1], s[2]): s for s in result.series_before}
    after = {(s[0], s[1], s[2]): s for s in result.series_after}
    groups = {"tones": [k for k in before if k[0] in (
                  "R10", "R23", "R5lo", "R5hi", "gate_balance", "red_blue", "gate_power")],
              "gates": [k for k in before if k[0] in ("F_pop", "imb", "C", "P00_t", "P11_t")],
              "calibration": [k for k in before if k[0].startswith("calibration")]}
    out = Path(outdir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    with staged_outputs() as stage:
        for g, keys in groups.items():
            if not keys:
                continue
            n = len(keys)
            cols = 4 if n > 4 else n
            rows = -(-n // cols)
            fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.4 * rows), squeeze=False)
            for ax, k in zip(axes.flat, keys):
                _, sb, d, xname, x, z = before[k]
                ax.axhline(0, color="k", lw=0.5)
                ax.plot(x, z, "o", ms=3, color="0.6", label="baseline")
                if k in after and result.chosen is not None:
                    ax.plot(after[k][4], after[k][5], "o", ms=3, color="C3",
                            label=result.chosen.effect)
                for m in result.mismatches:
                    if (m["observable"], m["sideband"], -1 if m["dpd"] is None else m["dpd"]) == k:
                        ax.axvspan(*m["range"], color="C1", alpha=0.2)
                ax.set_title(f"{k[0]} {sb} " + ("" if d < 0 else f"dpd={d}"), fontsize=8)
                ax.set_xlabel(xname, fontsize=7)
                ax.set_ylabel("z", fontsize=7)
                ax.tick_params(labelsize=6)
            for ax in list(axes.flat)[n:]:
                ax.axis("off")
            axes.flat[0].legend(fontsize=6)
            fig.suptitle(f"standardised residuals: baseline vs {result.verdict}", fontsize=9)
            fig.tight_layout()
            name = f"diagnosis_{g}.png"
            fig.savefig(stage(out / name), dpi=DIAGNOSIS_DPI, format="png")
            plt.close(fig)
            paths.append(str(out / name))
    return paths
