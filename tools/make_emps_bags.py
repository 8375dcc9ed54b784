"""Convert the EMPS benchmark MAT files into the MCAP bags bundled in bags/.

Usage: python tools/make_emps_bags.py [EMPS_DATA_DIR] [OUT_DIR]
(defaults: ../shared/data/emps and bags/). Topics (1 kHz, joint 'emps'):
  /joint_states     sensor_msgs/JointState  position = qm (m), effort = gtau·vir (N)
  /joint_reference  sensor_msgs/JointState  position = qg (m), the position set-point
  /drive_pulses     sensor_msgs/JointState  effort = pulses_N (V) added after saturation (validation only)
Bag custom data holds gtau (N/V), kp (1/s), kv (V·s/m) and tec (s), the period t(10) − t(9)
the benchmark's Simulink model runs at.
"""

import shutil
import sys
from pathlib import Path

from frictionid_core.io import load_emps_mat, write_joint_state_bag

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    data_dir = Path(sys.argv[1]) if len(sys.argv) > 1 else ROOT.parent / "shared" / "data" / "emps"
    out_dir = Path(sys.argv[2]) if len(sys.argv) > 2 else ROOT / "bags"
    for mat, name in (("DATA_EMPS.mat", "emps_estimation"), ("DATA_EMPS_PULSES.mat", "emps_validation")):
        series = load_emps_mat(data_dir / mat)
        series.meta["tec"] = float(series.t[9] - series.t[8])  # the benchmark clock period, s
        extra = {"/joint_reference": ("position", series.extras["qg"])}
        if "pulses" in series.extras:
            extra["/drive_pulses"] = ("effort", series.extras["pulses"])
        target = out_dir / name
        if target.exists():
            shutil.rmtree(target)
        write_joint_state_bag(target, series, extra_topics=extra)
        size = sum(f.stat().st_size for f in target.iterdir())
        print(f"{target}: {len(series)} samples, {size / 1e6:.2f} MB")


if __name__ == "__main__":
    main()
