"""EMPS report: model comparison, output error, grey + black-box ensembles, study, figures.

``frictionid report emps --out DIR [--study STUDY_DIR]`` writes ``DIR/report.html`` (figures
embedded, self-contained), the PNG files and ``DIR/report.json``. The report of one result on any
system and source is :mod:`frictionid_core.reports.result_report`; both draw with
:mod:`frictionid_core.reports.html_page`.
"""

from __future__ import annotations

import base64
import html
import time
from pathlib import Path

import numpy as np

from frictionid_core.files import write_bytes, write_json, write_text
from frictionid_core.friction import all_models
from frictionid_core.model import improvement_pct
from frictionid_core.reports import PAGE_STYLE, friction_axes, html_table, png_bytes


def model_table(series) -> list[dict]:
    """Thesis Table 6.3: every friction model by local search (ls, or lm with variable projection)."""
    from frictionid_core.identification import IdentifyRequest, SolverOptions, identify

    rows = []
    for m in all_models():
        solver = "ls" if m.is_linear else "lm"
        res = identify(series, IdentifyRequest(friction=m.name, asymmetric=m.asymmetric,
                                               solver=SolverOptions(solver, varpro=not m.is_linear)))
        rows.append({"model": m.label, "solver": solver + ("" if m.is_linear else "+varpro"), "params": res.params,
                     **{k: res.metrics[k] for k in ("relerr_pct", "r2", "rmse", "error_std")}, "result": res})
    worst = max(r["relerr_pct"] for r in rows)
    for r in rows:
        r["delta_pct"] = improvement_pct(r["relerr_pct"], worst)
    return rows


def figures(series, best_row: dict, sim_val, study_runs: list[dict] | None) -> dict[str, bytes]:
    """PNG figures: friction curve, OSA prediction/error, simulated position error, convergence."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from frictionid_core.identification import build_model

    out = {}
    res = best_row["result"]
    model = build_model(series, "emps", res.friction, res.asymmetric)
    x = np.array([res.params[n] for n in model.names])
    v = model.obs.velocity[:, 0]
    rigid = model.obs.rigid[:, 0] * res.params["M"] + res.params.get("offset", 0.0) * model.obs.columns[0]["one"]
    fparams = np.array([res.params[n] for n in model.friction.names])
    fig, ax = plt.subplots(figsize=(7, 4))
    friction_axes(ax, v, model.obs.y - rigid, model.friction, fparams, ("N", "m/s"),
                  "measured (force − M·q̈ − offset)")
    ax.set(ylabel="friction force (N)", title="Identified friction vs measured friction")
    out["friction_curve.png"] = png_bytes(fig)
    plt.close(fig)

    pred = model.predict(x)
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    a1.plot(model.obs.t, model.obs.y, lw=0.8, label="measured force")
    a1.plot(model.obs.t, pred, lw=0.8, label="OSA prediction")
    a1.set_ylabel("force (N)")
    a1.legend(fontsize=8)
    a2.plot(model.obs.t, model.obs.y - pred, lw=0.8, color="C3")
    a2.set(xlabel="time (s)", ylabel="error (N)")
    a1.set_title(f"OSA torque prediction ({v.size} decimated samples)")
    out["osa_prediction.png"] = png_bytes(fig)
    plt.close(fig)

    sim, sims = sim_val
    fig, ax = plt.subplots(figsize=(8, 3.5))
    for label, s in sims.items():
        ax.plot(sim.t, (sim.q_ref - s.q.ravel()) * 1e6, lw=0.8, label=label)
    ax.set(xlabel="time (s)", ylabel="q_measured − q_simulated (µm)",
           title="Simulated position error, validation run, true clock")
    ax.legend(fontsize=8)
    out["position_error.png"] = png_bytes(fig)
    plt.close(fig)

    if study_runs:
        from frictionid_core.emps.study import convergence

        conv = convergence(study_runs)
        fig, (a1, a2) = plt.subplots(1, 2, figsize=(10, 3.8))
        for a, c in conv.items():
            a1.semilogy(np.arange(1, c["fmin_rel"].size + 1), c["fmin_rel"] - 1 + 1e-12, label=a)
            a2.semilogy(np.arange(1, c["dist_mean"].size + 1), c["dist_mean"], label=a)
        a1.set(xlabel="generation G", ylabel="f_min(G)/f_min(final) − 1", title="Convergence (median of runs)")
        a2.set(xlabel="generation G", ylabel="dist_mean(G) (normalised)", title="Mean population distance")
        a1.legend(fontsize=8)
        out["convergence.png"] = png_bytes(fig)
        plt.close(fig)
    return out


def build_report(estimation: Path, validation: Path, out_dir: Path, study_dir: Path | None = None,
                 ensemble_members: int = 5) -> dict:
    """Compute everything, write the PNGs, ``report.json`` and ``report.html``; return the JSON dict."""
    from frictionid_core.emps.ensemble import grey_black_ensemble
    from frictionid_core.emps.output_error import identify_output_error
    from frictionid_core.emps.simulation import EmpsSimulator, load_emps
    from frictionid_core.identification import IdentifyRequest
    from frictionid_core.io import load

    t0 = time.perf_counter()
    out_dir.mkdir(parents=True, exist_ok=True)
    series = load(estimation)
    rows = model_table(series)
    est, val = load_emps(estimation), load_emps(validation)

    def sim_errors(friction: str, asym: bool, params: dict) -> dict:
        out = {}
        for clock in ("true", "benchmark"):
            for tag, data in (("est", est), ("val", val)):
                s = EmpsSimulator(data, friction, asym, clock=clock, offset="offset" in params)
                out[f"{tag}_{clock}"] = float(s.position_relerr(s.as_array(params))[0])
        return out

    for r in rows:
        friction, asym = r["result"].friction, r["result"].asymmetric
        r["sim"] = sim_errors(friction, asym, r["params"])
    # Output error: choose the model on estimation data only.
    oe = {}
    for friction, asym in (("coulomb", True), ("tustin", True)):
        res = identify_output_error(estimation, IdentifyRequest(friction=friction, asymmetric=asym, solver="lm"))
        oe[f"{friction}{'-asym' if asym else ''}"] = {"params": res.params,
                                                       "sim": sim_errors(friction, asym, res.params)}
    best_oe = min(oe, key=lambda k: oe[k]["sim"]["est_true"])
    ens = []
    for label, friction, asym, params in (("coulomb (benchmark reference)", "coulomb", False, rows[0]["params"]),
                                          (f"{best_oe} (output error)", best_oe.split("-")[0],
                                           best_oe.endswith("asym"), oe[best_oe]["params"])):
        e = grey_black_ensemble(est, val, params, friction, asym, members=ensemble_members).to_dict()
        ens.append({"label": label, **e})
    study = None
    study_runs = None
    if study_dir is not None:
        from frictionid_core.emps.study import analyse, load_runs

        study = analyse(study_dir)
        study_runs = load_runs(study_dir)
    best_row = min(rows, key=lambda r: r["relerr_pct"])
    sim_val = EmpsSimulator(val, "coulomb", False)
    oe_friction = best_oe.split("-")[0]
    sim_oe = EmpsSimulator(val, oe_friction, best_oe.endswith("asym"))
    sims = {"IDM Coulomb (reference)": sim_val.simulate(rows[0]["params"]),
            f"output error {best_oe}": sim_oe.simulate(oe[best_oe]["params"])}
    figs = figures(series, best_row, (sim_val, sims), study_runs)
    for name, data in figs.items():
        write_bytes(out_dir / name, data)
    report = {"estimation": str(estimation), "validation": str(validation),
              "models": [{k: v for k, v in r.items() if k != "result"} for r in rows],
              "output_error": oe, "best_output_error": best_oe, "ensembles": ens, "study": study,
              "wall_s": time.perf_counter() - t0}
    write_json(out_dir / "report.json", report)
    write_text(out_dir / "report.html", _html(report, figs))
    return report


def _html(rep: dict, figs: dict[str, bytes]) -> str:
    img = lambda name: (f'<img alt="{name}" src="data:image/png;base64,{base64.b64encode(figs[name]).decode()}">'
                        if name in figs else "")
    parts = ["<!doctype html><html><head><meta charset='utf-8'><title>frictionid EMPS report</title><style>",
             PAGE_STYLE + "</style></head><body>",
             "<h1>EMPS friction identification report</h1>",
             f"<p>Estimation: <code>{html.escape(rep['estimation'])}</code>; validation: "
             f"<code>{html.escape(rep['validation'])}</code>. Position errors are relative errors 100·‖y−ŷ‖/‖y‖ (%). "
             "<b>true</b> clock: recorded time stamps; <b>benchmark</b> clock: the benchmark's constant period "
             "(comparable with the literature, but most of its error is clock drift).</p>",
             "<h2>Friction models by local search (thesis Table 6.3)</h2>",
             html_table(["model", "solver", "OSA relerr %", "R²", "RMSE N", "s N", "Δ %", "sim val true %",
                         "sim val benchmark %"],
                        [[r["model"], r["solver"], r["relerr_pct"], r["r2"], r["rmse"], r["error_std"], r["delta_pct"],
                          r["sim"]["val_true"], r["sim"]["val_benchmark"]] for r in rep["models"]]),
             img("friction_curve.png"), img("osa_prediction.png"),
             "<h2>Output-error identification</h2><p>The closed-loop simulator inside the optimiser (lm from the IDM "
             f"result). Chosen on estimation data: <b>{html.escape(rep['best_output_error'])}</b>.</p>",
             html_table(["model", "sim est true %", "sim val true %", "sim est benchmark %", "sim val benchmark %"],
                        [[k, v["sim"]["est_true"], v["sim"]["val_true"], v["sim"]["est_benchmark"],
                          v["sim"]["val_benchmark"]] for k, v in rep["output_error"].items()]),
             img("position_error.png"),
             "<h2>Grey + black-box ensembles (true clock)</h2>",
             html_table(["grey box", "ŷ1 est %", "ŷ1 val %", "ŷ2 est %", "ŷ2 val %", "ŷ3 val %", "Δ ŷ2 val %",
                         "Δ ŷ3 val %", "c", "w1", "w2"],
                        [[e["label"], e["errors_pct"]["gbm"]["est"], e["errors_pct"]["gbm"]["val"],
                          e["errors_pct"]["bgbm"]["est"], e["errors_pct"]["bgbm"]["val"],
                          e["errors_pct"]["egbb"]["val"], e["improvement_val_pct"]["bgbm"],
                          e["improvement_val_pct"]["egbb"], e["weights"]["c"], e["weights"]["w1"], e["weights"]["w2"]]
                         for e in rep["ensembles"]])]
    if rep.get("study"):
        from frictionid_core.emps.study import format_summary

        parts += ["<h2>Optimiser study (thesis §6.3)</h2>", f"<pre>{html.escape(format_summary(rep['study']))}</pre>",
                  img("convergence.png")]
    parts.append(f"<p><small>generated by frictionid in {rep['wall_s']:.0f} s</small></p></body></html>")
    return "\n".join(parts)
