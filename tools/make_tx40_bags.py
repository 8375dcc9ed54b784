"""Synthesise the TX40 MCAP bags bundled in bags/ (deterministic: fixed seeds).

Usage: python tools/make_tx40_bags.py [OUT_DIR]   (default bags/; existing tx40 bags are replaced)

Four recordings (~20 s) at 1 kHz of the six TX40 joints (sensor_msgs/JointState on
/joint_states, joints joint_1 … joint_6; position rad with docs/reference.md#tx40 noise, effort N·m with
0.05 N·m noise), symmetric Stribeck friction of docs/reference.md#tx40 (Fs of joints 5, 6 assumed 1.2·Fc):

  tx40_excitation     all joints follow one period of an optimised Fourier excitation (seed 1,
                      10 s), then 15 s of constant-velocity plateaus at ±(0.01, 0.03, 0.0625,
                      0.125) rad/s for the Stribeck shapes (25 s in all)
  tx40_validation     another optimised trajectory (seed 2, period 8 s, 20 s)
  tx40_j2_excitation  only joint 2 moves (seed 1, period 10 s, 20 s), the others held at 0 (arm upright):
                      the thesis joint-2 model τ = ZZ·q̈ − g·MX·cos θ + g·MY·sin θ + τ_f + offset
                      is then exact, with ZZ, MX, MY the effective values in the truth file
  tx40_j2_validation  only joint 2 moves (seed 2, period 8 s, 20 s)

The ground truth of each bag (standard and base parameters, friction, noise, trajectory
coefficients, thesis joint-2 equivalents) goes to OUT_DIR/tx40_truth.json. Equivalent CLI:

  frictionid excite --system tx40 --seed 1 --period 10 --duration 10 --dwell 15 --evals 1500 --out ex.npz
  frictionid synth ex.npz --system tx40 --friction stribeck --seed 11 --out bags/tx40_excitation --truth t.json
  frictionid excite --system tx40-j2 --seed 1 --period 10 --duration 20 --evals 600 --out j2.npz
  frictionid synth j2.npz --system tx40 --friction stribeck --seed 31 --out bags/tx40_j2_excitation
"""

import json
import shutil
import sys
import time
from pathlib import Path

from frictionid_core.excitation import add_dwell, optimise_excitation, robot_of
from frictionid_core.io import write_joint_state_bag
from frictionid_core.synthetic import synthesize
from frictionid_core.systems import get_system

ROOT = Path(__file__).resolve().parents[1]

# name: (system whose columns are conditioned, excitation seed, period s, evaluations, noise seed,
#        Fourier duration s, dwell s). The 15 s dwell gives σ(δ of joint 2) ≈ 2.2 %, so 1.96 σ < 5 %
#        (bench/tx40_stribeck_information.py); the Fourier motion alone gives 7–13 %.
BAGS = {
    "tx40_excitation": ("tx40", 1, 10.0, 1500, 11, 10.0, 15.0),
    "tx40_validation": ("tx40", 2, 8.0, 1500, 21, 20.0, 0.0),
    "tx40_j2_excitation": ("tx40-j2", 1, 10.0, 600, 31, 20.0, 0.0),
    "tx40_j2_validation": ("tx40-j2", 2, 8.0, 600, 41, 20.0, 0.0),
}
RATE = 1000.0


def main() -> None:
    out_dir = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT / "bags"
    out_dir.mkdir(parents=True, exist_ok=True)
    truths = {"generated_by": "tools/make_tx40_bags.py", "bags": {}}
    for name, (system_name, seed, period, evals, noise_seed, duration, dwell) in BAGS.items():
        t0 = time.perf_counter()
        system = get_system(system_name)
        robot, moving = robot_of(system, system_name)
        ex = optimise_excitation(system, robot, moving=moving, period=period, duration=duration, evals=evals,
                                 seed=seed)
        traj = add_dwell(robot, ex.trajectory, dwell) if dwell > 0 else ex.trajectory
        series, truth = synthesize(robot, traj, friction="stribeck", seed=noise_seed, rate=RATE, source=name)
        truth["trajectory"] = dict(traj.to_dict(), criterion_system=system_name, excitation_seed=seed,
                                   evaluations=evals, cond_unit_columns=ex.cond)
        target = out_dir / name
        if target.exists():
            shutil.rmtree(target)
        write_joint_state_bag(target, series)
        truths["bags"][name] = truth
        size = sum(f.stat().st_size for f in target.iterdir())
        print(f"{target}: {len(series)} samples × {len(series.joints)} joints, {size / 1e6:.2f} MB, "
              f"cond {ex.cond:.3g}, {time.perf_counter() - t0:.1f} s", flush=True)
    (out_dir / "tx40_truth.json").write_text(json.dumps(truths, indent=1) + "\n")
    print(f"{out_dir / 'tx40_truth.json'}: ground truth")


if __name__ == "__main__":
    main()
