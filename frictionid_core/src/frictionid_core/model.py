"""Inverse dynamic model + friction model on an observation: parameters → torque rows.

The parameter vector is: rigid-body parameters, then per joint the friction parameters (in
the friction model's order), then per joint the constant ``offset`` (symmetric models only:
with an asymmetric model the offset is collinear with the two Coulomb columns).
With more than one joint, per-joint names are prefixed ``<joint>/``.

Every parameter except the nonlinear friction shape parameters (vs, v0, delta) enters the
prediction linearly; :meth:`IdentificationModel.solve_linear` exploits that.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import FrictionModel
from frictionid_core.observation import Observation


@dataclass
class _Term:
    """A linear parameter's column: a fixed column (rows) plus, optionally, ∓ a dip column."""

    name: str
    index: int  # position in the full parameter vector
    joint: int
    fixed: np.ndarray | None  # (R,) rows, or None for the pure dip column (Fs)
    dip_branch: int | None = None  # which dip this term carries
    dip_sign: float = 0.0  # +1 (Fs), −1 (Fc of tustin/stribeck/threlfall)


@dataclass
class _Dip:
    """One branch of one joint whose shape depends on nonlinear parameters."""

    joint: int
    nl_index: list[int]  # indices of (vs[, delta]) or (v0) in the full parameter vector
    mask: np.ndarray  # (Nd,) branch selector × sign(v) at the decimated velocity
    speed: np.ndarray  # (Nd,) |v|


@dataclass
class _ActiveDip:
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
        (dᵀd (P,), dᵀy (P,), dᵀF (P, L)) — see :mod:`frictionid_core.dipsums`."""
        from frictionid_core.dipsums import dip_sums  # numba: only models with a dip need it

        dd, dy, dF_nz = dip_sums(friction.name, p[:, self.nl_index], self.speed, self.log_speed, self.mask,
                                 self.Ft_nz, self.y_rows)
        dF = np.zeros((p.shape[0], self.F_rows.shape[1]))
        dF[:, self.F_cols] = dF_nz
        return dd, dy, dF


@dataclass
class IdentificationModel:
    """Torque prediction and least-squares cost of ``friction`` on ``obs``.

    Args:
        obs: decimated observation data.
        friction: the friction model, applied to every joint.
        offset: include a constant offset per joint (default: symmetric models only).
        rigid_bounds: {rigid name: (lo, hi)} search bounds of the rigid-body parameters.
        bound_overrides: {name: (lo, hi)} replacing default bounds; a name may be a full
            parameter name (``joint_2/vs_pos``), a base name (``vs_pos``) or a family (``vs``).
    """

    obs: Observation
    friction: FrictionModel
    offset: bool | None = None
    rigid_bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    bound_overrides: dict[str, tuple[float, float]] = field(default_factory=dict)

    def __post_init__(self) -> None:
        if self.offset is None:
            self.offset = not self.friction.asymmetric
        obs = self.obs
        nd, nj = obs.n_samples, len(obs.joints)
        rows = nj * nd
        names = list(obs.rigid_names)
        terms: list[_Term] = [_Term(n, i, -1, obs.rigid[:, i]) for i, n in enumerate(obs.rigid_names)]
        dips: list[_Dip] = []
        fnames = self.friction.names
        law = self.friction.law
        nb = len(self.friction.branch_names)
        for j in range(nj):
            prefix = f"{obs.joints[j]}/" if nj > 1 else ""
            base = len(names)
            names += [prefix + n for n in fnames]
            branches = [("pos", "_pos", nb * 0), ("neg", "_neg", nb)] if self.friction.asymmetric else [("", "", 0)]
            v = obs.velocity[:, j]
            for tag, suffix, off in branches:
                cols = obs.columns[j]
                vcol, scol = cols["V" + suffix], cols["S" + suffix]
                mask = np.sign(v) * {"pos": v > 0, "neg": v < 0, "": np.ones_like(v, bool)}[tag]
                dip_id = None
                nl = [base + off + k for k, n in enumerate(self.friction.branch_names) if n in law.nonlinear]
                if nl:
                    dip_id = len(dips)
                    dips.append(_Dip(j, nl, mask, np.abs(v)))
                for k, n in enumerate(self.friction.branch_names):
                    idx = base + off + k
                    if n == "Fv":
                        terms.append(_Term(names[idx], idx, j, _place(vcol, j, nj, nd)))
                    elif n == "Fc":
                        terms.append(_Term(names[idx], idx, j, _place(scol, j, nj, nd), dip_id,
                                           -1.0 if dip_id is not None else 0.0))
                    elif n == "Fs":
                        terms.append(_Term(names[idx], idx, j, None, dip_id, 1.0))
        if self.offset:
            for j in range(nj):
                prefix = f"{obs.joints[j]}/" if nj > 1 else ""
                names.append(prefix + "offset")
                terms.append(_Term(names[-1], len(names) - 1, j, _place(obs.columns[j]["one"], j, nj, nd)))
        self.names = names
        self._terms = terms
        self._dips = dips
        self.linear_index = np.array([t.index for t in terms])
        self.nonlinear_index = np.array(sorted(i for d in dips for i in d.nl_index), dtype=int)
        # Fixed design columns of every linear term (R, L); zero column for pure-dip terms.
        self._fixed = np.column_stack([t.fixed if t.fixed is not None else np.zeros(rows) for t in terms])
        self._rows, self._nd = rows, nd
        self._quadratic = self._quadratic_terms()

    def _quadratic_terms(self) -> tuple:
        """Constant pieces of the cost and of :meth:`solve_linear`: FᵀF, Fᵀy, yᵀy and, per dip
        compacted to the rows where its branch is active, its nonlinear-parameter indices, speeds
        |v| and log|v|, signed mask, rows of F and y, and the ± signs of the terms it enters."""
        F, y, nd = self._fixed, self.obs.y, self._nd
        dips = []
        for k, d in enumerate(self._dips):
            active = np.flatnonzero(d.mask)
            rows = d.joint * nd + active
            speed = d.speed[active]
            sign = np.array([t.dip_sign if t.dip_branch == k else 0.0 for t in self._terms])
            dips.append(_ActiveDip(d.nl_index, speed, np.log(np.maximum(speed, 1e-300)), d.mask[active],
                                   np.ascontiguousarray(F[rows]), y[rows], sign, np.outer(sign, sign)))
        return F.T @ F, F.T @ y, float(y @ y), dips

    # ----------------------------------------------------------------- structure
    @property
    def k(self) -> int:
        return len(self.names)

    @property
    def is_linear(self) -> bool:
        return self.nonlinear_index.size == 0

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Default search bounds (lower, upper), each (k,)."""
        flo, fhi = self.friction.default_bounds()
        lo, hi = np.empty(self.k), np.empty(self.k)
        nf = len(self.friction.names)
        for i, n in enumerate(self.obs.rigid_names):
            lo[i], hi[i] = self.rigid_bounds.get(n, (-1e3, 1e3))
        r = len(self.obs.rigid_names)
        for j in range(len(self.obs.joints)):
            lo[r + j * nf : r + (j + 1) * nf], hi[r + j * nf : r + (j + 1) * nf] = flo, fhi
        if self.offset:
            scale = float(np.max(np.abs(self.obs.y))) if self.obs.y.size else 1.0
            lo[-len(self.obs.joints):], hi[-len(self.obs.joints):] = -0.5 * scale, 0.5 * scale
        unknown = set(self.bound_overrides)
        for i, name in enumerate(self.names):
            base = name.rsplit("/", 1)[-1]
            for key in (name, base, base.removesuffix("_pos").removesuffix("_neg")):
                if key in self.bound_overrides:
                    lo[i], hi[i] = self.bound_overrides[key]
                    unknown.discard(key)
                    break
        if unknown:
            raise FrictionIdError(f"bounds given for unknown parameter(s) {sorted(unknown)}; parameters: {self.names}")
        return lo, hi

    # --------------------------------------------------------------- prediction
    def _dip_columns(self, theta: np.ndarray) -> list[np.ndarray]:
        """Per dip: (P, Nd) signed dip shape at the decimated velocity."""
        out = []
        for d in self._dips:
            shape = self.friction.dip(theta[:, d.nl_index], d.speed)
            out.append(shape * d.mask[None, :])
        return out

    def predict(self, params: np.ndarray) -> np.ndarray:
        """Torque rows for parameters (P, k) → (P, R), or (k,) → (R,)."""
        p = np.asarray(params, dtype=float)
        single = p.ndim == 1
        p = np.atleast_2d(p)
        if p.shape[1] != self.k:
            raise FrictionIdError(f"model takes {self.k} parameters {self.names}, got {p.shape[1]}")
        coef = p[:, self.linear_index]
        pred = coef @ self._fixed.T
        if self._dips:
            dipcols = self._dip_columns(p)
            nd = self._nd
            for t, c in zip(self._terms, coef.T):
                if t.dip_branch is None:
                    continue
                d = self._dips[t.dip_branch]
                pred[:, d.joint * nd : (d.joint + 1) * nd] += t.dip_sign * c[:, None] * dipcols[t.dip_branch]
        return pred[0] if single else pred

    def batch_cost(self, params: np.ndarray) -> np.ndarray:
        """Sum of squared torque residuals for a population (P, k) → (P,).

        Expanded through the constant normal-equation pieces, ‖y − Fc − Σ_d w_d·D_d‖² =
        yᵀy − 2cᵀFᵀy + cᵀFᵀFc + Σ_d [w_d²·D_dᵀD_d − 2w_d·D_dᵀ(y − Fc)] (the dips D_d act on
        disjoint rows), so each candidate costs BLAS products over the dips' active rows only.
        """
        p = np.atleast_2d(np.asarray(params, dtype=float))
        if p.shape[1] != self.k:
            raise FrictionIdError(f"model takes {self.k} parameters {self.names}, got {p.shape[1]}")
        FtF, Fty, yty, dips = self._quadratic
        c = p[:, self.linear_index]
        cost = yty - 2.0 * (c @ Fty) + np.einsum("pl,pl->p", c @ FtF, c)
        for d in dips:
            dd, dy, dF = d.sums(self.friction, p)
            w = c @ d.sign
            cost += w * (w * dd - 2.0 * (dy - np.einsum("pl,pl->p", dF, c)))
        return np.maximum(cost, 0.0)

    def residuals(self, params: np.ndarray) -> np.ndarray:
        """y − ŷ for one parameter vector (k,) → (R,)."""
        return self.obs.y - self.predict(np.asarray(params, dtype=float))

    # ------------------------------------------------------- separable structure
    def design(self, theta: np.ndarray | None = None) -> np.ndarray:
        """Design matrix of the linear parameters: (R, L) when ``theta`` is None (linear models),
        else (P, R, L) for the nonlinear parameters held in ``theta`` (P, k) (other entries ignored)."""
        if theta is None:
            if not self.is_linear:
                raise FrictionIdError(f"{self.friction.label}: the design matrix depends on the nonlinear parameters")
            return self._fixed
        p = np.atleast_2d(theta)
        X = np.broadcast_to(self._fixed, (p.shape[0],) + self._fixed.shape).copy()
        dipcols = self._dip_columns(p)
        nd = self._nd
        for col, t in enumerate(self._terms):
            if t.dip_branch is not None:
                d = self._dips[t.dip_branch]
                X[:, d.joint * nd : (d.joint + 1) * nd, col] += t.dip_sign * dipcols[t.dip_branch]
        return X

    def solve_linear(self, theta: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Variable projection: for each row of ``theta`` (P, k) keep its nonlinear entries and
        solve the linear ones in closed form. Returns (full parameters (P, k), costs (P,)).

        The normal equations are updated from the constant FᵀF with the few dip columns only
        (dips act on disjoint rows), so a population costs O(P·active rows·L).
        """
        p = np.array(np.atleast_2d(theta), dtype=float)
        FtF, Fty, yty, dips = self._quadratic
        n_pop, n_lin = p.shape[0], FtF.shape[0]
        G = np.repeat(FtF[None], n_pop, axis=0)
        b = np.repeat(Fty[None], n_pop, axis=0)
        for d in dips:
            dd, dy, dF = d.sums(self.friction, p)
            outer = dF[:, :, None] * d.sign[None, None, :]  # Fᵀ·dip ⊗ signs
            G += outer + outer.transpose(0, 2, 1) + dd[:, None, None] * d.sign2
            b += dy[:, None] * d.sign
        scale = 1.0 / np.sqrt(np.maximum(np.einsum("pll->pl", G), np.finfo(float).tiny))
        Gs = G * scale[:, :, None] * scale[:, None, :] + 1e-12 * np.eye(n_lin)
        coef = np.linalg.solve(Gs, (b * scale)[..., None])[..., 0] * scale
        p[:, self.linear_index] = coef
        cost = yty - 2.0 * np.einsum("pl,pl->p", coef, b) + np.einsum("pl,plm,pm->p", coef, G, coef)
        return p, np.maximum(cost, 0.0)


def _place(col: np.ndarray, j: int, nj: int, nd: int) -> np.ndarray:
    out = np.zeros(nj * nd)
    out[j * nd : (j + 1) * nd] = col
    return out
