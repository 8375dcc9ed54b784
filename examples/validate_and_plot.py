"""Identify on the EMPS estimation bag, cross-test on the validation bag, plot the force.

    python examples/validate_and_plot.py [OUT_DIR]

Prints the fit on both runs and saves OUT_DIR/validation_force.png (default: the current
folder): measured force and the force the identified model predicts from the measured motion,
on the validation run (which has 5 V force pulses the model never saw).
"""

import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import frictionid_core as fid
from frictionid_core.identification import build_model

BAGS = Path(__file__).resolve().parents[1] / "bags"


def main(argv: list[str]) -> int:
    out = Path(argv[0]) if argv else Path.cwd()
    request = fid.IdentifyRequest(system="emps", friction="coulomb", solver="ls")
    result = fid.identify(fid.load(BAGS / "emps_estimation"), request)
    validation = fid.load(BAGS / "emps_validation")
    metrics = fid.validate(validation, result)
    print(f"relative error: estimation {result.metrics['relerr_pct']:.5g} %, "
          f"validation {metrics['relerr_pct']:.5g} %")

    # The same observation validate() used: filtered, differentiated, decimated by 10.
    model = build_model(validation, result.system, result.friction, result.asymmetric)
    predicted = model.predict(np.array([result.params[n] for n in model.names]))
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 5), sharex=True)
    top.plot(model.obs.t, model.obs.y, lw=0.8, label="measured")
    top.plot(model.obs.t, predicted, lw=0.8, label="predicted (identified on the estimation run)")
    top.set(ylabel="force (N)", title=f"EMPS validation run: relative error {metrics['relerr_pct']:.3g} %")
    top.legend(fontsize=8)
    bottom.plot(model.obs.t, model.obs.y - predicted, lw=0.8, color="C3")
    bottom.set(xlabel="time (s)", ylabel="error (N)")
    out.mkdir(parents=True, exist_ok=True)
    path = out / "validation_force.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
