"""The calibrated AOM transfer function, its inverse and the predistortion table.

Forward model (Supplement S6.1, Eq. S11)::

    y(t) = f_AM(|x(t)|) * exp(i [theta(t) + f_PM(|x(t)|)])

with ``f_AM`` the K=8 amplitude polynomial, odd (``f_AM(-x) = -f_AM(x)``) and
with ``|x|`` clipped to 1, and ``f_PM`` the K=5 phase polynomial, even (a
function of ``|x|`` only).

Inverse (Methods, "Digital predistortion scheme"; Fig. 1c)
----------------------------------------------------------
``f_AM^{-1}`` maps a target optical amplitude in ``[0, A_corr]``
(``A_corr = y(1)``) to the RF amplitude that produces it, by a vectorised
bracketed root solve (Chandrupatla's method, ``scipy.optimize.elementwise``)
to 1e-12 or better in ``y``; targets beyond ``A_corr`` are clamped to full
drive (``A = 1``).  The inverse is the branch starting at the origin:
``x(t) = min{A : y(A) = t}``.  It exists when y increases on ``[0, A*]``,
``A*`` being the first amplitude with ``y(A*) = A_corr``.  If the fitted
curve has a local maximum *below* ``A_corr`` (``dy/dA <= 0`` before reaching
``A_corr``) the table cannot be built and :class:`NotInvertibleError` names
the amplitude.  A curve that peaks slightly above ``A_corr`` and rolls off
towards ``A = 1`` (the physical AOM has its diffraction maximum at ``A = 1``,
so a fit may overshoot a little) is invertible: the table reaches ``A_corr``
at ``A* < 1`` and is clamped to full drive beyond it, which gives the same
optical output.  ``strict=True`` refuses that case too.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import brentq
from scipy.optimize.elementwise import find_root

from dpdfit.fits.calibration import Calibration, nonmonotone_intervals
from dpdfit.errors import InputError, NotInvertibleError

__all__ = ["TransferFunction", "predistortion_table"]


def _poly(A, powers, coef):
    """sum_k c_k A^k by Horner's rule over the dense coefficient list."""
    dense = np.zeros(max(powers) + 1)
    for p, c in zip(powers, coef):
        dense[p] += c
    return np.polynomial.polynomial.polyval(A, dense)


@dataclass(frozen=True)
class TransferFunction:
    """Static AM/PM transfer function of the AOM (paper, Supplement Eq. S11).

    Parameters
    ----------
    am_powers, am_coefficients : sequence
        Normalised amplitude polynomial ``y(A) = sum a_k A^k`` (unit slope).
    pm_powers, pm_coefficients : sequence, optional
        Phase polynomial ``phi(A)`` in rad; absent means no AM-to-PM.
    source : str, optional
        Where the fit comes from (the calibration file, or the recorded CSV
        and run); it starts the message of a :class:`NotInvertibleError`.
    """

    am_powers: tuple
    am_coefficients: tuple
    pm_powers: tuple = ()
    pm_coefficients: tuple = ()
    source: str | None = field(default=None, compare=False, repr=False)
    _branch_top: tuple | None = field(init=False, repr=False, compare=False)

    def __post_init__(self):
        object.__setattr__(self, "am_powers", tuple(int(p) for p in self.am_powers))
        object.__setattr__(self, "am_coefficients", tuple(float(c) for c in self.am_coefficients))
        object.__setattr__(self, "pm_powers", tuple(int(p) for p in self.pm_powers))
        object.__setattr__(self, "pm_coefficients", tuple(float(c) for c in self.pm_coefficients))
        object.__setattr__(self, "_branch_top", None)

    @classmethod
    def from_calibration(cls, cal: Calibration, source: str | None = None
                         ) -> "TransferFunction":
        """The transfer function of a calibration; ``source`` names it in messages
        (default: the ``calibration.json`` it was loaded from, else the fitted CSV)."""
        ph = cal.phase
        if source is None:
            source = cal.file or cal.amplitude.source.get("file")
        return cls(cal.amplitude.powers, tuple(cal.amplitude.coefficients),
                   () if ph is None else ph.powers,
                   () if ph is None else tuple(ph.coefficients), source=source)

    def _where(self) -> str:
        """``"c.json: "``, the prefix of a message (empty without a source)."""
        return f"{self.source}: " if self.source else ""

    # ------------------------------------------------------------------ forward
    @property
    def A_corr(self) -> float:
        """y(1): the maximum correctable amplitude."""
        return float(sum(self.am_coefficients))

    def y(self, A):
        """The amplitude polynomial y(A), unclipped, for A in [0, 1]."""
        return _poly(np.asarray(A, dtype=float), self.am_powers, self.am_coefficients)

    def f_am(self, x):
        """Amplitude response ``f_AM(x)``: odd, ``|x|`` clipped to 1 (S6.1)."""
        x = np.asarray(x, dtype=float)
        return np.sign(x) * self.y(np.minimum(np.abs(x), 1.0))

    def f_pm(self, x):
        """Phase response ``f_PM(x)`` in rad: even, ``|x|`` clipped to 1 (S6.1)."""
        x = np.abs(np.asarray(x, dtype=float))
        if not self.pm_powers:
            return np.zeros_like(x)
        return _poly(np.minimum(x, 1.0), self.pm_powers, self.pm_coefficients)

    def forward(self, x, am_only: bool = False):
        """Optical field for an RF envelope ``x`` (real or complex), Eq. S11.

        Parameters
        ----------
        x : array_like
            RF envelope samples (normalised units, ``|x| = A``).
        am_only : bool
            Drop the phase response (AM-only model).

        Returns
        -------
        ndarray of complex
        """
        x = np.asarray(x)
        mag = np.abs(x)
        theta = np.angle(x)
        phase = theta if am_only else theta + self.f_pm(mag)
        return self.y(np.minimum(mag, 1.0)) * np.exp(1j * phase)

    # ------------------------------------------------------------------ inverse
    def invertibility(self) -> tuple[float, list]:
        """``(A_star, rolloff)``: the top of the invertible branch and any roll-off.

        Raises
        ------
        NotInvertibleError
            If dy/dA <= 0 somewhere before y first reaches A_corr.
        """
        if self._branch_top is not None:
            return self._branch_top
        Ac = self.A_corr
        bad = nonmonotone_intervals(self.am_coefficients, self.am_powers)
        if Ac <= 0:
            raise NotInvertibleError(f"{self._where()}fitted y(1) = {Ac:.6g} <= 0: the "
                                     "amplitude fit is not a usable transfer function", 1.0)
        if not bad:
            top = (1.0, [])
        else:
            a0 = bad[0][0]   # first amplitude where dy/dA turns negative
            if self.y(a0) < Ac:
                raise NotInvertibleError(
                    f"{self._where()}amplitude fit is not invertible on [0, A_corr={Ac:.6f}]: dy/dA <= 0 at "
                    f"A = {a0:.6f} (y has a local maximum {float(self.y(a0)):.6f} below A_corr; "
                    f"dy/dA < 0 on " + ", ".join(f"[{a:.4f}, {b:.4f}]" for a, b in bad) + ")",
                    a0)
            # y peaks at a0 above A_corr, then rolls off: branch ends where y = A_corr
            a_star = a0 if self.y(a0) == Ac else brentq(
                lambda a: float(self.y(a)) - Ac, 0.0, a0, xtol=1e-15, rtol=1e-15)
            top = (float(a_star), bad)
        object.__setattr__(self, "_branch_top", top)
        return top

    def inverse_am(self, target, *, strict: bool = False):
        """RF amplitude that produces the optical amplitude ``target``: f_AM^{-1}.

        Parameters
        ----------
        target : array_like
            Desired normalised optical amplitude(s).  Signed values are mapped
            odd-symmetrically; ``|target| >= A_corr`` is clamped to full drive.
        strict : bool
            Also refuse a fit that rolls off after its peak (see module doc).

        Returns
        -------
        ndarray
            RF amplitude(s) in [-1, 1], accurate so that
            ``|f_AM(result) - target| <= 1e-12`` on ``[0, A_corr]``.
        """
        a_star, rolloff = self.invertibility()
        if strict and rolloff:
            a0 = rolloff[0][0]
            raise NotInvertibleError(
                f"{self._where()}amplitude fit is not monotone on [0, 1]: dy/dA <= 0 at A = {a0:.6f} "
                f"(rolls off after its peak; strict inversion requested)", a0)
        t = np.asarray(target, dtype=float)
        mag = np.abs(t)
        Ac = self.A_corr
        out = np.ones_like(mag)
        inside = mag < Ac
        if np.any(inside):
            tt = mag[inside]
            res = find_root(lambda a, tt: self.y(a) - tt, (np.zeros_like(tt), np.full_like(tt, a_star)),
                            args=(tt,), tolerances=dict(xatol=1e-16, xrtol=4e-16, fatol=1e-15, frtol=0.0))
            x = np.where(tt == 0, 0.0, res.x)
            out[inside] = x
        return np.sign(t) * out if np.any(t < 0) else out

    def predistort(self, waveform):
        """Apply DPD sample by sample to a real envelope (S3): ``f_AM^{-1}(w)``."""
        return self.inverse_am(waveform)


def predistortion_table(tf: TransferFunction, n_points: int, *, strict: bool = False):
    """N-point predistortion table on a uniform grid of target amplitudes 0..1.

    Returns
    -------
    target, rf, clamped : ndarray
        Target optical amplitude (unit-slope normalised), the RF amplitude
        that produces it, and a boolean mask of targets >= A_corr that are
        clamped to full drive.
    """
    if n_points < 2:
        raise InputError(f"a predistortion table needs at least 2 points, got {n_points}")
    target = np.linspace(0.0, 1.0, int(n_points))
    rf = tf.inverse_am(target, strict=strict)
    return target, rf, target >= tf.A_corr
