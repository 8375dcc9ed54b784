"""What the data of a fit resolve (:func:`identifiability`): the numerical rank of its scaled
observation matrix, the directions it leaves unresolved, and what the fit does with them.

The columns are those of the linear parameters (rigid-body, Fv, Fc, offset…; a pure dip term
such as Fs has no column of its own before its shape is known) on the fit's used rows. A column
below :data:`ZERO_TOL` of the largest has no effect; each other one is scaled to unit norm; a
QR with column pivoting (``scipy.linalg.qr``) orders them by how much each adds to those before
it, and a pivot |R_kk| below :data:`RANK_TOL` (the first is ≈ 1) ends the rank:
the columns left after it are the unresolved directions, named by their parameters. Exact ties
(columns equal on these data) keep friction before rigid-body parameters before offsets, so the
names do not depend on round-off (a joint moving one way keeps its Coulomb level and drops its
offset, as ``--fix offset=0`` would).

An unresolved parameter is held (as a fixed value, moved to the right-hand side) so that the
others are the base combinations of these data: at 0 (``dropped``: its effect folds into the
parameters it is collinear with, named in ``folded_into``), or at the robot model's own value
(``prior``). Parameters the user fixed are left to the user (``fixed`` when they cover a
deficiency). Only a parameter with no effect at all on a joint that moves is worth a refusal,
and that case (a joint whose friction has no usable row) is refused before, by the direction
check of :mod:`frictionid_core.identification.diagnostics`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from frictionid_core.model import IdentificationModel

# A column whose pivot, among unit-norm columns, falls below this share of the first one's is
# unresolved: its estimate would carry at least 1e6 × the noise the best-determined direction
# carries (σ ∝ σ_e / |R_kk|), i.e. the torque would need a signal-to-noise ratio above 1e6
# (120 dB) to fix it to its own size; round-off of float64 columns (≈ 1e-13 after filtering
# and decimation) sits far below.
RANK_TOL = 1e-6
# A column whose norm is below this share of the largest one is zero: round-off of a column that
# vanishes in this configuration (≈ 1e-16 of the largest, relative) or the filter's residue on a
# joint that does not accelerate (a ramp's q̈ after the trims: ≈ 1e-8), which scaling to unit norm
# would turn into a spurious direction; the smallest motion a log resolves stays far above it (a
# q̈ of 1e-3 rad/s² against a gravity column of 9.81 N·m per unit is 1e-4 of it).
ZERO_TOL = 1e-6
# A parameter named among a direction's dominant ones carries at least this share of its largest term.
DOMINANT_SHARE = 0.1
# Tie-break between equal columns: the k-th of C columns (in the tie order) is scaled by 1 − TIE_BREAK·k/C.
TIE_BREAK = 1e-12
_LISTED = 8  # unresolved parameters named in the warning


@dataclass
class Identifiability:
    """What the data resolve (the result's ``identifiability`` block, :meth:`to_dict`).

    Attributes:
        rank: numerical rank of the scaled columns.
        columns: columns checked (linear parameters with a column of their own).
        unresolved: parameters the data leave unresolved (those the user fixed included).
        action: ``dropped`` (held at 0), ``prior`` (held at the robot model's value), ``fixed``
            (the user's fixed values cover them) or None (every direction resolved).
        held: {parameter: value} the fit holds (those of ``unresolved`` it did not leave to the user).
        folded_into: {unresolved parameter: {resolved parameter: coefficient}}: its column as a
            combination of the resolved ones (dominant terms), so each of those estimates holds
            its own value + coefficient × the unresolved one.
        no_effect: the unresolved parameters whose column is zero on the fit's rows.
    """

    rank: int
    columns: int
    unresolved: list[str] = field(default_factory=list)
    action: str | None = None
    held: dict[str, float] = field(default_factory=dict)
    folded_into: dict[str, dict[str, float]] = field(default_factory=dict)
    no_effect: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"rank": self.rank, "columns": self.columns, "unresolved": list(self.unresolved),
                "action": self.action, "tolerance": RANK_TOL, "held": dict(self.held),
                "folded_into": {k: dict(v) for k, v in self.folded_into.items()}, "no_effect": list(self.no_effect)}

    def warning(self, robot: bool = True) -> list[str]:
        """One line naming the unresolved parameters and what was done with them (none when all
        resolved); ``robot``: a robot system, whose URDF values ``--prior urdf`` can hold them at."""
        if not self.held:
            return []
        names = list(self.held)
        shown = []
        for name in names[:_LISTED]:
            fold = self.folded_into.get(name)
            if fold:
                shown.append(f"{name} (≈ " + " + ".join(f"{c:.3g}·{k}" for k, c in list(fold.items())[:3]) + ")")
            else:
                shown.append(f"{name} (no effect on the fitted rows)")
        more = f", … ({len(names)} in all)" if len(names) > _LISTED else ""
        head = (f"the data do not resolve {len(names)} direction(s) of the model (rank {self.rank} of "
                f"{self.columns}): {', '.join(shown)}{more}")
        if self.action == "prior":
            return [f"{head}: held at the robot model's values (--prior urdf; no model value: 0), σ undetermined"]
        prior = "hold them at the URDF values with --prior urdf, " if robot else ""
        return [f"{head}: dropped (held at 0, σ undetermined; each effect folds into the parameters it is collinear "
                f"with); {prior}fix them with --fix NAME=VALUE, or record motion that excites them"]


def identifiability(model: IdentificationModel, prior: dict[str, float] | None = None) -> Identifiability:
    """The identifiability of ``model``'s linear parameters on its used rows (see the module doc);
    ``prior``: {parameter: value} to hold unresolved parameters at (action ``prior``; a parameter
    it lacks is held at 0), else they are dropped.

    The columns are resolved in groups, each against those resolved before it: without a prior
    all free columns at once (ties to friction, then rigid body, then offsets), with a prior the
    friction and offset columns first and the rigid-body ones after them (so what stays
    unresolved is what the prior knows), the user's fixed columns last."""
    from scipy import linalg

    cols = [k for k, t in enumerate(model._terms) if t.fixed is not None]
    index = model.linear_index[cols]
    names = [model.names[i] for i in index]
    rigid = np.array([model._terms[k].joint < 0 for k in cols], dtype=bool)
    offset = np.array([n.rsplit("/", 1)[-1] == "offset" for n in names], dtype=bool)
    X = model._fixed[model.obs.used][:, cols]
    norms = np.linalg.norm(X, axis=0)
    user_fixed = np.array([i in model.fixed_values for i in index], dtype=bool)
    zero = norms <= ZERO_TOL * norms.max(initial=0.0)
    # the triangular factor of the unit-norm columns keeps their relations in C rows instead of R
    S = np.linalg.qr(X / np.where(zero, 1.0, norms), mode="r")
    tie = np.empty(len(cols))  # each column's place in the tie order: friction, rigid body, offsets
    tie[np.lexsort((np.arange(len(cols)), np.where(offset, 2, np.where(rigid, 1, 0))))] = np.arange(len(cols))
    scaled = S * (1.0 - TIE_BREAK * tie / max(1, len(cols)))
    live = ~zero & ~user_fixed
    groups = [live & ~rigid, live & rigid] if prior is not None else [live]
    unresolved: list[int] = [int(k) for k in np.flatnonzero(zero & ~user_fixed)]
    rank = 0
    basis = np.zeros((S.shape[0], 0))
    for group in [np.flatnonzero(g) for g in groups] + [np.flatnonzero(~zero & user_fixed)]:
        if group.size == 0:
            continue
        A = scaled[:, group]
        for _ in range(2):  # re-orthogonalised against the columns already resolved
            A = A - basis @ (basis.T @ A)
        Q, R, piv = linalg.qr(A, mode="economic", pivoting=True)
        r = int(np.sum(np.abs(np.diag(R)) > RANK_TOL))
        rank += r
        basis = np.hstack([basis, Q[:, :r]])
        unresolved += [int(group[p]) for p in piv[r:]]
    unresolved_fixed = [k for k in unresolved if user_fixed[k]] + [int(k) for k in np.flatnonzero(zero & user_fixed)]
    dropped = sorted(k for k in unresolved if not user_fixed[k])
    out = Identifiability(rank, len(cols), [names[k] for k in sorted(dropped + unresolved_fixed)])
    if dropped:
        out.action = "dropped" if prior is None else "prior"
        out.held = {names[k]: float((prior or {}).get(names[k], 0.0)) for k in dropped}
        out.no_effect = [names[k] for k in dropped if zero[k]]
        out.folded_into = _folds(S, norms, names, dropped, user_fixed | zero)
    elif unresolved_fixed:
        out.action = "fixed"
    return out


def _folds(S: np.ndarray, norms: np.ndarray, names: list[str], dropped: list[int], left: np.ndarray
           ) -> dict[str, dict[str, float]]:
    """{dropped parameter: {kept parameter: coefficient}}: each dropped column (those of ``left``,
    fixed or without effect, aside) as the least-squares combination of the kept ones, its
    dominant terms (in parameter units); ``S``: the triangular factor of the unit-norm columns."""
    kept = [k for k in range(S.shape[1]) if k not in dropped and not left[k]]
    out = {}
    live = [k for k in dropped if not left[k]]
    if not kept or not live:
        return out
    coef = np.linalg.lstsq(S[:, kept], S[:, live], rcond=None)[0]
    for c, k in enumerate(live):
        share = np.abs(coef[:, c])
        top = share.max(initial=0.0)
        order = [i for i in np.argsort(-share) if share[i] >= DOMINANT_SHARE * top and top > 0]
        # column_k = Σ a_i·column_i (unit-norm a) → coefficient in parameter units a_i·‖X_k‖/‖X_i‖
        out[names[k]] = {names[kept[i]]: float(coef[i, c] * norms[k] / norms[kept[i]]) for i in order}
    return out
