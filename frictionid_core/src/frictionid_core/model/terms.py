"""The terms of an :class:`~frictionid_core.model.identification_model.IdentificationModel`: a linear
parameter's column, a friction dip, a dip on its active rows with the pieces its cost needs."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from frictionid_core.friction import FrictionModel


@dataclass
class Term:
    """A linear parameter's column: a fixed column (rows) plus, optionally, ∓ a dip column."""

    name: str
    index: int  # position in the full parameter vector
    joint: int
    fixed: np.ndarray | None  # (R,) rows, or None for the pure dip column (Fs)
    dip_branch: int | None = None  # which dip this term carries
    dip_sign: float = 0.0  # +1 (Fs), −1 (Fc of tustin/stribeck/threlfall)


@dataclass
class Dip:
    """One branch of one joint whose shape depends on nonlinear parameters."""

    joint: int
    nl_index: list[int]  # indices of (vs[, delta]) or (v0) in the full parameter vector
    mask: np.ndarray  # (Nd,) branch selector × sign(v) at the decimated velocity
    speed: np.ndarray  # (Nd,) |v|


@dataclass
class ActiveDip:
    """A dip restricted to its active rows, with the constant pieces the cost needs."""

    nl_index: list[int]
    speed: np.ndarray  # |v| on the active rows
    log_speed: np.ndarray  # log|v| (the rows are active only where v ≠ 0)
    mask: np.ndarray  # signed branch mask on the active rows
    F_rows: np.ndarray  # fixed design rows (n, L)
    y_rows: np.ndarray  # measured torque rows (n,)
    sign: np.ndarray  # (L,) ±1 for the linear terms the dip enters, 0 elsewhere
    sign2: np.ndarray  # outer(sign, sign)
    F_cols: np.ndarray = field(init=False)  # columns of F_rows not all zero (the others add nothing to dᵀF)
    Ft_nz: np.ndarray = field(init=False)  # F_rows[:, F_cols]ᵀ (L', n), contiguous

    def __post_init__(self):
        self.F_cols = np.flatnonzero(np.any(self.F_rows != 0.0, axis=0))
        self.Ft_nz = np.ascontiguousarray(self.F_rows[:, self.F_cols].T)

    def sums(self, friction: FrictionModel, p: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For parameters (P, k), the signed dip column d on the active rows reduced to
        (dᵀd (P,), dᵀy (P,), dᵀF (P, L)) — see :mod:`frictionid_core.friction.kernels`."""
        from frictionid_core.friction import dip_sums  # numba: only models with a dip need it

        dd, dy, dF_nz = dip_sums(friction.name, p[:, self.nl_index], self.speed, self.log_speed, self.mask,
                                 self.Ft_nz, self.y_rows)
        dF = np.zeros((p.shape[0], self.F_rows.shape[1]))
        dF[:, self.F_cols] = dF_nz
        return dd, dy, dF

def place(col: np.ndarray, j: int, nj: int, nd: int) -> np.ndarray:
    """``col`` (Nd,) as joint j's block of J·Nd joint-major rows (zero elsewhere)."""
    out = np.zeros(nj * nd)
    out[j * nd : (j + 1) * nd] = col
    return out
