"""Inverse dynamic model + friction model on an observation: parameters → torque rows.

The parameter vector is: rigid-body parameters, then per joint the friction parameters (in
the friction model's order), then per joint the constant ``offset`` (symmetric models only:
with an asymmetric model the offset is collinear with the two Coulomb columns), then with
``load_rigid`` per joint its load-dependent Coulomb level ``Fc_load``.
With more than one joint, per-joint names are prefixed ``<joint>/``.

Every parameter except the nonlinear friction shape parameters (vs, v0, delta) enters the
prediction linearly; :meth:`IdentificationModel.solve_linear` exploits that.

One constraint policy holds in every solver, the closed forms (``ls``, variable projection)
included (docs/cli.md#constraints): parameters that cannot be negative (:func:`cannot_be_negative`:
friction levels, masses, inertias, rotor inertias) are ≥ 0; the bounds grounded in the data
(``data_bounds``: the friction dip's speed within the data's speeds, Fs within a factor of the
Coulomb level) and the user's bounds hold wherever a parameter is solved or searched. Searching
solvers also need a finite box (:meth:`IdentificationModel.bounds`): its other limits are a search
range only.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from frictionid_core.errors import FrictionIdError
from frictionid_core.friction import FrictionModel
from frictionid_core.model.least_squares import box_quadratic, least_squares
from frictionid_core.model.load_dependence import LOAD_BOUNDS, LOAD_NAME, load_columns, load_names
from frictionid_core.model.observation import Observation
from frictionid_core.model.parameter_names import cannot_be_negative, parameter_keys
from frictionid_core.model.terms import ActiveDip, Dip, Term, place


@dataclass
class IdentificationModel:
    """Torque prediction and least-squares cost of ``friction`` on ``obs``.

    Args:
        obs: decimated observation data.
        friction: the friction model, applied to every joint.
        offset: include a constant offset per joint (default: symmetric models only).
        rigid_bounds: {rigid name: (lo, hi)} search bounds of the rigid-body parameters.
        bound_overrides: {name: (lo, hi)} the user's bounds, replacing default bounds; a name may
            be a full parameter name (``joint_2/vs_pos``), a base name (``vs_pos``) or a family
            (``vs``). Unlike the default bounds, they also hold for the linear parameters solved
            in closed form (:meth:`solve_linear`, :meth:`fit_linear`).
        fixed: {name: value} parameters held at a value (names as in ``bound_overrides``): never
            searched nor solved for, wherever they enter (a fixed linear parameter's column moves
            to the right-hand side, dip included).
        data_bounds: {full name: (lo, hi)} bounds grounded in the data (see
            :func:`frictionid_core.identification.linear_case.data_bounds`), over the defaults and
            under the user's bounds (they replace the defaults); held by every solver path, like
            the user's.
        physical: hold the parameters that cannot be negative at ≥ 0 in every solver path (the
            user's bounds of a parameter replace its sign constraint).
        load_rigid: rigid-body parameters (R,) whose torque sets the load-dependent Coulomb
            columns (``<joint>/Fc_load`` after the offsets: :mod:`frictionid_core.model.load_dependence`);
            None: no load dependence.
    """

    obs: Observation
    friction: FrictionModel
    offset: bool | None = None
    rigid_bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    bound_overrides: dict[str, tuple[float, float]] = field(default_factory=dict)
    fixed: dict[str, float] = field(default_factory=dict)
    data_bounds: dict[str, tuple[float, float]] = field(default_factory=dict)
    physical: bool = True
    load_rigid: np.ndarray | None = None

    def __post_init__(self) -> None:
        if self.offset is None:
            self.offset = not self.friction.asymmetric
        obs = self.obs
        nd, nj = obs.n_samples, len(obs.joints)
        rows = nj * nd
        names = list(obs.rigid_names)
        terms: list[Term] = [Term(n, i, -1, obs.rigid[:, i]) for i, n in enumerate(obs.rigid_names)]
        dips: list[Dip] = []
        fnames = self.friction.names
        law = self.friction.law
        dynamic = law.is_dynamic  # its level and states are not linear: only Fv is (DynamicIdentificationModel)
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
                if tag:  # a branch: selector × sign(v) at the decimated velocity, weighted like the others
                    mask = np.sign(v) * (v > 0 if tag == "pos" else v < 0)
                    if obs.weight is not None:
                        mask = mask * obs.weight
                    if obs.joint_weight is not None:
                        mask = mask * obs.joint_weight[j]
                else:  # the decimated sign column (weighted like the others): the dip's sign step
                    mask = scol  # anti-aliased as the effort's is
                dip_id = None
                nl = [base + off + k for k, n in enumerate(self.friction.branch_names)
                      if n in law.nonlinear and not dynamic]
                if nl:
                    dip_id = len(dips)
                    dips.append(Dip(j, nl, mask, np.abs(v)))
                for k, n in enumerate(self.friction.branch_names):
                    idx = base + off + k
                    if n == "Fv":
                        terms.append(Term(names[idx], idx, j, place(vcol, j, nj, nd)))
                    elif n == "Fc" and not dynamic:
                        terms.append(Term(names[idx], idx, j, place(scol, j, nj, nd), dip_id,
                                           -1.0 if dip_id is not None else 0.0))
                    elif n == "Fs" and not dynamic:
                        terms.append(Term(names[idx], idx, j, None, dip_id, 1.0))
        if self.offset:
            for j in range(nj):
                prefix = f"{obs.joints[j]}/" if nj > 1 else ""
                names.append(prefix + "offset")
                terms.append(Term(names[-1], len(names) - 1, j, place(obs.columns[j]["one"], j, nj, nd)))
        if self.load_rigid is not None:
            for j, (name, col) in enumerate(zip(load_names(obs.joints), load_columns(obs, self.load_rigid))):
                names.append(name)
                terms.append(Term(name, len(names) - 1, j, place(col, j, nj, nd)))
        self.names = names
        self._terms = terms
        self._dips = dips
        self.linear_index = np.array([t.index for t in terms])
        self.nonlinear_index = np.array(sorted(i for d in dips for i in d.nl_index), dtype=int)
        # Fixed design columns of every linear term (R, L); zero column for pure-dip terms.
        self._fixed = np.column_stack([t.fixed if t.fixed is not None else np.zeros(rows) for t in terms])
        self._rows, self._nd = rows, nd
        self._quadratic = self._quadratic_terms()
        self._constraints()

    @property
    def normal_equations(self) -> tuple[np.ndarray, np.ndarray]:
        """(FᵀF, Fᵀy): the normal equations of the linear terms' fixed design F (R, L) and the effort."""
        return self._quadratic[0], self._quadratic[1]

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
            dips.append(ActiveDip(d.nl_index, speed, np.log(np.maximum(speed, 1e-300)), d.mask[active],
                                   np.ascontiguousarray(F[rows]), y[rows], sign, np.outer(sign, sign)))
        return F.T @ F, F.T @ y, float(y @ y), dips

    def _constraints(self) -> None:
        """Resolve the user's bounds and fixed values to parameter indices; the linear terms' box
        (L,) that :meth:`solve_linear` enforces: fixed values (lo = hi), the user's bounds, else the
        data's bounds and the sign of the parameters that cannot be negative."""
        self.user_bounds = self._resolve(self.bound_overrides, "bounds")
        unknown = sorted(set(self.data_bounds) - set(self.names))
        if unknown:
            raise FrictionIdError(f"data bounds given for unknown parameter(s) {unknown}; parameters: {self.names}")
        self.grounded_bounds = {self.names.index(n): (float(lo), float(hi)) for n, (lo, hi) in
                                self.data_bounds.items()}
        for i, (lo, hi) in self.grounded_bounds.items():
            if not lo < hi:
                raise FrictionIdError(f"data bounds of {self.names[i]}: lower {lo} is not below upper {hi}")
        self.fixed_values = {i: float(v) for i, v in self._resolve(self.fixed, "fixed value").items()}
        for i, (lo, hi) in self.user_bounds.items():
            if not lo <= hi:
                raise FrictionIdError(f"bounds of {self.names[i]}: lower {lo} is above upper {hi}")
        for i, v in self.fixed_values.items():
            if not np.isfinite(v):
                raise FrictionIdError(f"fixed value of {self.names[i]} must be finite, got {v}")
            lo, hi = self.user_bounds.get(i, (v, v))
            if not lo <= v <= hi:
                raise FrictionIdError(f"fixed value {v} of {self.names[i]} lies outside its bounds [{lo}, {hi}]")
        for i, (lo, hi) in self.user_bounds.items():
            if lo == hi:  # a zero-width bound is a fixed value (a search cannot vary it)
                self.fixed_values.setdefault(i, float(lo))
        n_lin = self.linear_index.size
        self._lin_lo, self._lin_hi = np.full(n_lin, -np.inf), np.full(n_lin, np.inf)
        for pos, i in enumerate(self.linear_index):
            if i in self.fixed_values:
                self._lin_lo[pos] = self._lin_hi[pos] = self.fixed_values[i]
            elif i in self.user_bounds:
                self._lin_lo[pos], self._lin_hi[pos] = self.user_bounds[i]
            else:
                if i in self.grounded_bounds:
                    self._lin_lo[pos], self._lin_hi[pos] = self.grounded_bounds[i]
                if self.physical and cannot_be_negative(self.names[i]):
                    self._lin_lo[pos] = max(self._lin_lo[pos], 0.0)
        self._lin_constrained = bool(np.isfinite(self._lin_lo).any() or np.isfinite(self._lin_hi).any())

    def _resolve(self, overrides: dict, what: str) -> dict[int, object]:
        """{parameter index: value} of ``overrides`` keyed by a full name, a base name or a family
        (the first of :func:`parameter_keys` that a parameter matches); FrictionIdError for a key
        matching none."""
        out, unknown = {}, set(overrides)
        for i, name in enumerate(self.names):
            for key in parameter_keys(name):
                if key in overrides:
                    out[i] = overrides[key]
                    unknown.discard(key)
                    break
        if unknown:
            raise FrictionIdError(f"{what} given for unknown parameter(s) {sorted(unknown)}; parameters: {self.names}")
        return out

    def restricted(self, keep: np.ndarray) -> IdentificationModel:
        """This model on the instants where ``keep`` (Nd,) is True only (a hold-out's training
        rows): the other rows zeroed and unused, so they add nothing to any cost; the same
        bounds (the data's too) and fixed values."""
        drop = ~np.asarray(keep, dtype=bool)
        obs, nd = self.obs, self.obs.n_samples
        rows = (np.arange(len(obs.joints))[:, None] * nd + np.flatnonzero(drop)[None, :]).ravel()
        y, rigid, used = obs.y.copy(), obs.rigid.copy(), obs.used.copy()
        y[rows], rigid[rows], used[rows] = 0.0, 0.0, False
        part = replace(obs, y=y, rigid=rigid, used=used, velocity=np.where(drop[:, None], 0.0, obs.velocity),
                       columns=[{k: np.where(drop, 0.0, v) for k, v in c.items()} for c in obs.columns], sampled=None)
        return type(self)(part, self.friction, self.offset, self.rigid_bounds, self.bound_overrides, self.fixed,
                          self.data_bounds, self.physical, self.load_rigid)

    # ----------------------------------------------------------------- structure
    @property
    def k(self) -> int:
        return len(self.names)

    @property
    def is_linear(self) -> bool:
        """No nonlinear parameter at all (see :attr:`searched_nonlinear_index` for those not fixed)."""
        return self.nonlinear_index.size == 0

    @property
    def free_index(self) -> np.ndarray:
        """Indices of the parameters not fixed (what a full search varies)."""
        return np.array([i for i in range(self.k) if i not in self.fixed_values], dtype=int)

    @property
    def searched_nonlinear_index(self) -> np.ndarray:
        """Indices of the nonlinear parameters not fixed (what variable projection searches)."""
        return np.array([i for i in self.nonlinear_index if i not in self.fixed_values], dtype=int)

    @property
    def linear_box(self) -> tuple[np.ndarray, np.ndarray]:
        """(lower, upper) (L,) of the linear terms (``linear_index`` order) that the closed-form
        solves enforce: fixed values (lower = upper) and the user's bounds; ±inf elsewhere."""
        return self._lin_lo, self._lin_hi

    def embed(self, values: np.ndarray, index: np.ndarray) -> np.ndarray:
        """Full parameter rows (P, k) holding ``values`` (P, m) at ``index`` (m,), the fixed values,
        and zeros elsewhere."""
        values = np.atleast_2d(values)
        full = np.zeros((values.shape[0], self.k))
        for i, v in self.fixed_values.items():
            full[:, i] = v
        full[:, index] = values
        return full

    def held_at_box(self, x: np.ndarray) -> set[str]:
        """The linear parameters of ``x`` (k,) held at a bound of the linear box (not fixed): the
        constraints active in the closed form, which σ then treats as known."""
        c = np.asarray(x, dtype=float)[self.linear_index]
        lo, hi = self._lin_lo, self._lin_hi
        at = (lo < hi) & (((c == lo) & np.isfinite(lo)) | ((c == hi) & np.isfinite(hi)))
        return {self.names[i] for i in self.linear_index[at]}

    def physical_bound(self, i: int) -> bool:
        """True when parameter ``i`` is held ≥ 0 by the sign constraint (no user bound or value of its own)."""
        return (self.physical and cannot_be_negative(self.names[i]) and i not in self.user_bounds
                and i not in self.fixed_values)

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """Search bounds (lower, upper), each (k,): the defaults (lower 0 for the parameters that
        cannot be negative), the data's bounds within them, the user's bounds over them, and
        lower = upper = the value of a fixed parameter."""
        flo, fhi = self.friction.default_bounds()
        lo, hi = np.empty(self.k), np.empty(self.k)
        nf = len(self.friction.names)
        for i, n in enumerate(self.obs.rigid_names):
            lo[i], hi[i] = self.rigid_bounds.get(n, (-1e3, 1e3))
        r = len(self.obs.rigid_names)
        for j in range(len(self.obs.joints)):
            lo[r + j * nf : r + (j + 1) * nf], hi[r + j * nf : r + (j + 1) * nf] = flo, fhi
        kinds = np.array([n.rsplit("/", 1)[-1] for n in self.names])
        y = self.obs.y if self.obs.joint_weight is None else self.obs.unweighted().y
        scale = float(np.max(np.abs(y))) if y.size else 1.0
        lo[kinds == "offset"], hi[kinds == "offset"] = -0.5 * scale, 0.5 * scale
        lo[kinds == LOAD_NAME], hi[kinds == LOAD_NAME] = LOAD_BOUNDS
        for i, (low, high) in self.grounded_bounds.items():
            lo[i], hi[i] = low, high
        if self.physical:
            sign = np.array([cannot_be_negative(n) for n in self.names], dtype=bool)
            lo[sign] = np.maximum(lo[sign], 0.0)
        for i, (low, high) in self.user_bounds.items():
            lo[i], hi[i] = low, high
        for i, value in self.fixed_values.items():
            lo[i] = hi[i] = value
        return lo, hi

    def dip_rows(self) -> list[tuple[slice, np.ndarray]]:
        """Per dip: (the rows of its joint in the residual, the indices of its nonlinear parameters)."""
        nd = self._nd
        return [(slice(d.joint * nd, (d.joint + 1) * nd), np.asarray(d.nl_index, dtype=int)) for d in self._dips]

    # --------------------------------------------------------------- prediction
    def _dip_columns(self, theta: np.ndarray) -> list[np.ndarray]:
        """Per dip: (P, Nd) signed dip shape at the decimated velocity."""
        out = []
        for d in self._dips:
            shape = self.friction.dip(theta[:, d.nl_index], d.speed)
            out.append(shape * d.mask[None, :])
        return out

    def population(self, params: np.ndarray) -> tuple[np.ndarray, bool]:
        """(parameters as (P, k), whether one vector (k,) was given); FrictionIdError for another k."""
        p = np.asarray(params, dtype=float)
        single = p.ndim == 1
        p = np.atleast_2d(p)
        if p.shape[1] != self.k:
            raise FrictionIdError(f"model takes {self.k} parameters {self.names}, got {p.shape[1]}")
        return p, single

    def predict(self, params: np.ndarray) -> np.ndarray:
        """Torque rows for parameters (P, k) → (P, R), or (k,) → (R,)."""
        p, single = self.population(params)
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
        """Variable projection: for each row of ``theta`` (P, k) keep its nonlinear entries (fixed
        ones at their values) and solve the linear ones in closed form, within the user's bounds
        and at their fixed values. Returns (full parameters (P, k), costs (P,)).

        The normal equations are updated from the constant FᵀF with the few dip columns only
        (dips act on disjoint rows), so a population costs O(P·active rows·L).
        """
        p = np.array(np.atleast_2d(theta), dtype=float)
        for i, v in self.fixed_values.items():
            p[:, i] = v
        FtF, Fty, yty, dips = self._quadratic
        n_pop = p.shape[0]
        G = np.repeat(FtF[None], n_pop, axis=0)
        b = np.repeat(Fty[None], n_pop, axis=0)
        for d in dips:
            dd, dy, dF = d.sums(self.friction, p)
            outer = dF[:, :, None] * d.sign[None, None, :]  # Fᵀ·dip ⊗ signs
            G += outer + outer.transpose(0, 2, 1) + dd[:, None, None] * d.sign2
            b += dy[:, None] * d.sign
        coef = self._solve_normal(G, b)[0]
        p[:, self.linear_index] = coef
        cost = yty - 2.0 * np.einsum("pl,pl->p", coef, b) + np.einsum("pl,plm,pm->p", coef, G, coef)
        return p, np.maximum(cost, 0.0)

    def solve_normal(self, G: np.ndarray, b: np.ndarray) -> np.ndarray:
        """The linear parameters c (L,) (``linear_index`` order) minimising ½cᵀGc − bᵀc within the
        linear box, as every closed form here solves them: ``G`` (L, L) and ``b`` (L,) the normal
        equations FᵀF, Fᵀy of any rows of the linear columns (:meth:`design`)."""
        return self._solve_normal(np.asarray(G, dtype=float)[None], np.asarray(b, dtype=float)[None])[0][0]

    def _solve_normal(self, G: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray | None]:
        """argmin ½cᵀGc − bᵀc per candidate (G (P, L, L), b (P, L)) within the linear box (fixed
        values, user bounds): (c (P, L), which entries are held at a bound or fixed (P, L), or
        None without a box). Diagonally scaled, with a 1e-12 ridge for collinear columns."""
        n_lin = b.shape[1]
        scale = 1.0 / np.sqrt(np.maximum(np.einsum("pll->pl", G), np.finfo(float).tiny))
        Gs = G * scale[:, :, None] * scale[:, None, :] + 1e-12 * np.eye(n_lin)
        if not self._lin_constrained:
            return np.linalg.solve(Gs, (b * scale)[..., None])[..., 0] * scale, None
        lo, hi = self._lin_lo, self._lin_hi
        z, held = box_quadratic(Gs, b * scale, lo / scale, hi / scale)
        coef = np.clip(z * scale, lo, hi)  # rounding of the scaling must not step outside the box
        at = np.where(np.abs(coef - lo) <= np.abs(coef - hi), lo, hi)
        return np.where(held, at, coef), held

    def fit_linear(self) -> tuple[np.ndarray, dict[str, float], float]:
        """Closed-form least squares (QR) of the linear parameters, every nonlinear one fixed.

        Fixed parameters, and those held at a bound (the user's, the data's or a sign constraint;
        found on the normal equations), move to the right-hand side; σ is 0 for a fixed parameter
        and NaN at a bound.
        Returns (parameters (k,), σ by name, condition number of the solved columns).
        """
        if self.searched_nonlinear_index.size:
            raise FrictionIdError(
                f"solver 'ls' needs a model linear in its parameters; '{self.friction.label}' has nonlinear "
                f"parameter(s) {[self.names[i] for i in self.searched_nonlinear_index]}: use lm, de, pso, ga, … "
                "instead (or fix them with --fix NAME=VALUE)"
            )
        x = self.embed(np.empty((1, 0)), np.empty(0, dtype=int))[0]
        X = self.design() if self.is_linear else self.design(x[None])[0]
        y = self.obs.y
        names = [self.names[i] for i in self.linear_index]
        std = {self.names[i]: 0.0 for i in self.fixed_values}
        if not self._lin_constrained:
            fit = least_squares(X, y, names)
            x[self.linear_index] = fit.coef
            return x, {**dict(zip(names, map(float, fit.std))), **std}, fit.cond
        coef, held = (a[0] for a in self._solve_normal((X.T @ X)[None], (X.T @ y)[None]))
        free = ~held
        sd = np.full(len(names), np.nan)
        cond = float("nan")
        if not held.any():  # no bound active: the unconstrained solution, to the digit
            fit = least_squares(X, y, names)
            coef = np.clip(fit.coef, self._lin_lo, self._lin_hi)
            sd, cond = fit.std, fit.cond
        elif free.any():
            fit = least_squares(X[:, free], y - X[:, held] @ coef[held], [n for n, f in zip(names, free) if f])
            coef[free] = np.clip(fit.coef, self._lin_lo[free], self._lin_hi[free])
            sd[free], cond = fit.std, fit.cond
        x[self.linear_index] = coef
        return x, {**dict(zip(names, map(float, sd))), **std}, cond
