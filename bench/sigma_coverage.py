#!/usr/bin/env python
"""Coverage of σ across many truths: the share of identified parameters whose |error| ≤ 1.96 σ.

    .venv/bin/python bench/sigma_coverage.py [--keep DIR] [--families mujoco,variants,synthetic] [--quick]
                                             [--mujoco-offsets 0,3,6] [--variant-seeds 31,41] [--label NAME]

σ is honest when 1.96 σ covers about 95 % of the parameters it is given for, over many truths,
excitations and noise draws (the target of issue 38: 90–98 % for the calibrated σ). Every case runs
the command line (``frictionid identify … --json``, in a process of its own, with the interpreter
running this script: run it with another checkout's venv for that version's figures) and counts,
for the white σ (``std``) and the calibrated σ (``std_robust``), the parameters with a finite σ > 0,
not at a bound, whose truth lies within 1.96 σ:

* ``mujoco``: the arms of ``bench/groundtruth.py`` (MuJoCo UR5 with its own damping, frictionloss
  and armature hidden; the same with the core's law; the TX40 with MuJoCo's friction), the bench's
  excitation with seed offsets 0, 3, 6 (``--mujoco-offsets``); ``--known-rigid-body`` (the defaults otherwise: coulomb,
  ls): Fv, Fc and the rotor inertia of each joint (18 per log);
* ``variants``: the MuJoCo UR5 with other excitations (``excite --max-acc 3``, ``--period 5
  --duration 10``, ``--harmonics 3``, ``--collision``), two seeds each (``--variant-seeds``), as
  ``mujoco``; both print the largest |error| of Fv, Fc and of the armature over every joint;
* ``synthetic``: ``frictionid synth`` of the TX40 (its published friction, default noise) and the UR5
  (:data:`UR5_FRICTION`, torque noise 0.2 N·m) on excitations of seeds 1–3, Coulomb friction
  identified with the defaults, Stribeck with ``--friction stribeck --solver hybrid``: every
  identified base and friction parameter against ``frictionid compare --truth``'s expected values.

Logs are made on first use and kept with ``--keep DIR`` (a MuJoCo log takes minutes). Prints the
table and writes bench/results/sigma_coverage.{txt,json} (``sigma_coverage_custom`` with ``--families``
or ``--quick``; ``--label NAME``: sigma_coverage_NAME). (Not ``coverage.py``: a bench script of that name
would shadow the coverage package for every script run from bench/.)
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from _results import publish

BENCH = Path(__file__).resolve().parent
ROOT = BENCH.parent
FRICTIONID = [sys.executable, "-m", "frictionid_core.cli"]
Z95 = 1.96
TARGET = (0.90, 0.98)
MUJOCO_OFFSETS = (0, 3, 6)
VARIANTS = {"slow": ("--max-acc", "3"), "short": ("--period", "5", "--duration", "10"),
            "h3": ("--harmonics", "3"), "coll": ("--collision",)}
VARIANT_SEEDS = (31, 41)
SYNTH_SEEDS = (1, 2, 3)
EXCITE_EVALS = "600"
UR5_FRICTION = {"shoulder_pan_joint": (6.0, 7.0, 9.0), "shoulder_lift_joint": (5.0, 6.5, 8.0),
                "elbow_joint": (3.5, 4.5, 5.5), "wrist_1_joint": (1.2, 1.5, 2.0), "wrist_2_joint": (1.0, 1.4, 1.8),
                "wrist_3_joint": (0.8, 1.3, 1.6)}  # Fv, Fc, Fs; vs 0.05 rad/s, δ 2
UR5_TORQUE_NOISE = "0.2"


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def cli(*args: str) -> str:
    proc = subprocess.run([*FRICTIONID, *args], capture_output=True, text=True, cwd=ROOT)
    if proc.returncode:
        raise RuntimeError(f"frictionid {' '.join(args)}: {proc.stderr.strip().splitlines()[-1:]}")
    return proc.stdout


# ----------------------------------------------------------------------------------- logs
def mujoco_log(scenario: str, folder: Path, offset: int | None = None, seed: int | None = None,
               excite: tuple = ()) -> Path:
    """The estimation log of a groundtruth scenario: the bench's seeds + ``offset``, or excitation
    seed ``seed`` (noise seed + 10) with ``excite`` arguments; made once in ``folder``."""
    import groundtruth as g

    sc = g.scenarios()[scenario]
    folder.mkdir(parents=True, exist_ok=True)
    if offset is not None:
        return g.make_log(sc, folder, "estimation", offset)["bag"]
    bag, npz = folder / "estimation_bag", folder / "estimation.npz"
    if bag.exists() and npz.exists():
        return bag
    from frictionid_core.excitation import load_trajectory
    from frictionid_core.io import write_joint_state_bag
    from frictionid_core.timeseries import JointSeries

    traj = folder / "estimation_excitation.npz"
    g.run_cli("excite", "--system", sc.robot, "--out", str(traj), "--seed", str(seed), "--evals", EXCITE_EVALS,
              *excite)
    sim = g.simulate(sc, load_trajectory(traj))
    rng = np.random.default_rng(seed + 10)
    quantum = 2.0 * np.pi / g.ENCODER_COUNTS
    position = np.round(sim["q"] / quantum) * quantum
    sigma_tau = g.TORQUE_NOISE * np.ptp(sim["tau"], axis=0)
    effort = sim["tau"] + rng.standard_normal(sim["tau"].shape) * sigma_tau
    write_joint_state_bag(bag, JointSeries(sim["t"], sim["joints"], position, effort, source="estimation log"))
    np.savez(npz, position=position, effort=effort, torque_noise=sigma_tau, quantum=quantum,
             **{k: np.asarray(v) for k, v in sim.items()})
    return bag


def ur5_system() -> str:
    from frictionid_core.robots import example_robot_data_dir

    return f"urdf:{example_robot_data_dir() / 'ur_description' / 'urdf' / 'ur5_robot.urdf'}"


def synthetic_log(robot: str, law: str, seed: int, folder: Path) -> tuple[Path, Path, str]:
    """(bag, truth file, system) of ``frictionid synth`` on an excitation of ``seed``."""
    folder.mkdir(parents=True, exist_ok=True)
    system = "tx40" if robot == "tx40" else ur5_system()
    traj = folder / f"ex_{robot}_{seed}.npz"
    if not traj.exists():
        cli("excite", "--system", system, "--out", str(traj), "--seed", str(seed), "--evals", EXCITE_EVALS)
    bag, truth = folder / f"{robot}_{law}_{seed}", folder / f"{robot}_{law}_{seed}.truth.json"
    if not (bag.exists() and truth.exists()):
        extra = []
        if robot == "ur5":
            params = folder / "ur5_friction.json"
            params.write_text(json.dumps({j: {"Fv": fv, "Fc": fc, "Fs": fs, "vs": 0.05, "delta": 2.0}
                                          for j, (fv, fc, fs) in UR5_FRICTION.items()}))
            extra = ["--friction-params", str(params), "--torque-noise", UR5_TORQUE_NOISE]
        cli("synth", str(traj), "--system", system, "--friction", law, "--seed", str(seed + 100), "--out", str(bag),
            "--truth", str(truth), *extra)
    return bag, truth, system


# ------------------------------------------------------------------------------- coverage
def counts(errors: dict[str, float], sigma: dict, at_bound: dict) -> list[int]:
    """[covered, identified]: parameters of ``errors`` with a finite σ > 0 not at a bound, and those
    whose |error| ≤ 1.96 σ."""
    known = [n for n in errors if n not in at_bound and isinstance(sigma.get(n), (int, float))
             and np.isfinite(sigma[n]) and sigma[n] > 0]
    return [sum(abs(errors[n]) <= Z95 * sigma[n] for n in known), len(known)]


def mujoco_case(name: str, scenario: str, bag: Path, folder: Path) -> dict:
    import groundtruth as g

    sc = g.scenarios()[scenario]
    out = folder / f"{name}.json"
    t0 = time.perf_counter()
    cli("identify", str(bag), "--system", sc.robot, "--known-rigid-body", "--json", str(out))
    result = json.loads(out.read_text())
    joints = result["joints"]
    truth = {}
    for k, j in enumerate(joints):
        truth.update({f"{j}/Fv": sc.damping[k], f"{j}/Fc": sc.frictionloss[k], f"{j}.Ia": sc.armature[k]})
    record = case_record(name, result, truth, time.perf_counter() - t0)
    rel = {n: 100 * abs(result["params"][n] - v) / abs(v) for n, v in truth.items() if n in result["params"] and v}
    record["max_err_pct"] = {"friction": max(e for n, e in rel.items() if "/F" in n),
                             "armature": max(e for n, e in rel.items() if n.endswith(".Ia"))}
    return record


def synthetic_case(name: str, bag: Path, truth_file: Path, system: str, law: str, folder: Path) -> dict:
    out = folder / f"{name}.json"
    solver = ["--friction", "coulomb"] if law == "coulomb" else ["--friction", "stribeck", "--solver", "hybrid"]
    t0 = time.perf_counter()
    cli("identify", str(bag), "--system", system, *solver, "--json", str(out))
    wall = time.perf_counter() - t0
    compared = folder / f"{name}.compare.json"
    cli("compare", str(out), "--truth", str(truth_file), "--json", str(compared))
    rows = json.loads(compared.read_text())["parameters"]
    result = json.loads(out.read_text())
    return case_record(name, result, {n: r["truth"] for n, r in rows.items()}, wall)


def case_record(name: str, result: dict, truth: dict, wall: float) -> dict:
    errors = {n: result["params"][n] - v for n, v in truth.items() if n in result["params"]}
    at_bound = result.get("at_bound") or {}
    std, robust = result.get("std") or {}, result.get("std_robust") or {}
    worst = sorted(((abs(e) / robust[n], n) for n, e in errors.items()
                    if isinstance(robust.get(n), (int, float)) and np.isfinite(robust[n]) and robust[n] > 0),
                   reverse=True)[:3]
    return {"case": name, "white": counts(errors, std, at_bound), "calibrated": counts(errors, robust, at_bound),
            "at_bound": len([n for n in errors if n in at_bound]), "relerr_pct": result["metrics"]["relerr_pct"],
            "worst_z_calibrated": [[n, round(z, 2)] for z, n in worst], "wall_s": wall}


def cases(families: list[str], keep: Path, quick: bool, variant_seeds: tuple[int, ...] = VARIANT_SEEDS,
          mujoco_offsets: tuple[int, ...] = MUJOCO_OFFSETS) -> list[dict]:
    out = []
    work = keep / "results"
    work.mkdir(parents=True, exist_ok=True)
    if "mujoco" in families:
        for scenario in ("ur5_mujoco", "ur5_coulomb", "tx40_mujoco"):
            for offset in mujoco_offsets[: 1 if quick else None]:
                name = f"{scenario}+{offset}"
                log(f"[mujoco] {name} ...")
                bag = mujoco_log(scenario, keep / "mujoco" / f"{scenario}_{offset}", offset=offset)
                out.append({"family": "mujoco", **mujoco_case(name, scenario, bag, work)})
    if "variants" in families:
        for variant, args in VARIANTS.items():
            for seed in variant_seeds[: 1 if quick else None]:
                name = f"ur5_mujoco_{variant}_{seed}"
                log(f"[variants] {name} ...")
                bag = mujoco_log("ur5_mujoco", keep / "variants" / name, seed=seed, excite=args)
                out.append({"family": "variants", **mujoco_case(name, "ur5_mujoco", bag, work)})
    if "synthetic" in families:
        for robot in ("tx40", "ur5"):
            for law in ("coulomb", "stribeck"):
                for seed in SYNTH_SEEDS[: 1 if quick else None]:
                    name = f"{robot}_{law}_{seed}"
                    log(f"[synthetic] {name} ...")
                    bag, truth, system = synthetic_log(robot, law, seed, keep / "synthetic")
                    out.append({"family": "synthetic", **synthetic_case(name, bag, truth, system, law, work)})
    return out


def share(pairs: list[list[int]]) -> tuple[int, int, float]:
    hit, n = sum(p[0] for p in pairs), sum(p[1] for p in pairs)
    return hit, n, (hit / n if n else float("nan"))


def report(res: dict) -> str:
    lines = [f"coverage of 1.96 σ over many truths ({res['host']['python']}, {res['version']}, load "
             f"{res['host']['load_start']} → {res['host']['load_end']}, {res['wall_s']:.0f} s)",
             f"{'case':<32}{'white σ':>10}{'calibrated':>12}{'at bound':>10}{'relerr %':>10}  worst |error|/σ cal."]
    for c in res["cases"]:
        lines.append(f"{c['case']:<32}{'/'.join(map(str, c['white'])):>10}{'/'.join(map(str, c['calibrated'])):>12}"
                     f"{c['at_bound']:>10}{c['relerr_pct']:>10.3g}  "
                     + ", ".join(f"{n} {z}" for n, z in c["worst_z_calibrated"]))
    lines.append("")
    for family, s in res["summary"].items():
        lines.append(f"{family:<12} white σ {s['white'][0]}/{s['white'][1]} ({100 * s['white'][2]:.1f} %), calibrated "
                     f"σ (std_robust) {s['calibrated'][0]}/{s['calibrated'][1]} ({100 * s['calibrated'][2]:.1f} %)")
    errs = [c["max_err_pct"] for c in res["cases"] if "max_err_pct" in c]
    if errs:  # groundtruth.py's bars (issue 38's) for MuJoCo's friction with the rigid body known
        import groundtruth as g

        fr, ar = max(e["friction"] for e in errs), max(e["armature"] for e in errs)
        lines.append(f"MuJoCo arms (rigid body known): largest |error| of Fv, Fc {fr:.2f} % (≤ {g.FV_FC_TOL_PCT:g}), "
                     f"of the armature {ar:.2f} % (≤ {g.ARMATURE_TOL_PCT:g}): "
                     f"{'PASS' if fr <= g.FV_FC_TOL_PCT and ar <= g.ARMATURE_TOL_PCT else 'FAIL'}")
    lo, hi = TARGET
    cal = res["summary"]["all"]["calibrated"][2]
    lines.append(f"target: the calibrated σ covers {100 * lo:.0f}–{100 * hi:.0f} % of the identified parameters: "
                 f"{100 * cal:.1f} % {'PASS' if lo <= cal <= hi else 'FAIL'}")
    return "\n".join(lines)


def code_version() -> str:
    """The commit of the frictionid_core this interpreter runs (``git describe`` of its checkout)."""
    import frictionid_core

    where = Path(frictionid_core.__file__).resolve().parent
    return subprocess.run(["git", "-C", str(where), "describe", "--always", "--dirty"], capture_output=True,
                          text=True).stdout.strip() + f" ({where.parents[2].name})"


def int_list(text: str) -> tuple[int, ...]:
    """``"1,2,3"`` → (1, 2, 3) (an argparse type)."""
    return tuple(int(v) for v in text.split(","))


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--keep", type=Path, help="keep (and reuse) the logs and results in this folder")
    p.add_argument("--families", default="mujoco,variants,synthetic", help="comma-separated: mujoco, variants, "
                                                                            "synthetic")
    p.add_argument("--quick", action="store_true", help="one seed per family")
    p.add_argument("--mujoco-offsets", type=int_list, default=MUJOCO_OFFSETS,
                   help="comma-separated seed offsets of the mujoco family's logs (default "
                        f"{','.join(map(str, MUJOCO_OFFSETS))})")
    p.add_argument("--variant-seeds", type=int_list, default=VARIANT_SEEDS,
                   help="comma-separated excitation seeds of the variants family (default "
                        f"{','.join(map(str, VARIANT_SEEDS))})")
    p.add_argument("--label", help="results as bench/results/sigma_coverage_LABEL.{txt,json}")
    args = p.parse_args(argv)
    families = args.families.split(",")
    t0 = time.perf_counter()
    res = {"host": {"python": platform.python_version(), "cpus": os.cpu_count(),
                    "load_start": round(os.getloadavg()[0], 2)},
           "version": code_version(),
           "interpreter": sys.executable, "families": families}
    with tempfile.TemporaryDirectory(prefix="sigma_coverage_") as tmp:
        res["cases"] = cases(families, args.keep or Path(tmp), args.quick, args.variant_seeds, args.mujoco_offsets)
    res["wall_s"] = time.perf_counter() - t0
    res["host"]["load_end"] = round(os.getloadavg()[0], 2)
    res["summary"] = {f: {k: share([c[k] for c in res["cases"] if c["family"] == f]) for k in ("white", "calibrated")}
                      for f in families}
    res["summary"]["all"] = {k: share([c[k] for c in res["cases"]]) for k in ("white", "calibrated")}
    name = args.label and f"sigma_coverage_{args.label}" or (
        "sigma_coverage_custom" if args.quick or families != ["mujoco", "variants", "synthetic"] else "sigma_coverage")
    publish(name, report(res), res)
    return 0


if __name__ == "__main__":
    sys.exit(main())
