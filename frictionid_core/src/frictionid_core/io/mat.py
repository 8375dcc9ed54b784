"""The EMPS benchmark MAT files (Janot, Gautier, Brunot 2019)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from frictionid_core.errors import InputError
from frictionid_core.timeseries import JointSeries

EMPS_JOINT = "emps"
_REQUIRED = ("t", "qm", "vir", "gtau")


def load_emps_mat(path: Path) -> JointSeries:
    """Load an EMPS ``.mat`` file: position qm (m), force = gtau·vir (N).

    Extras: ``qg`` (reference position, m), ``vir`` (controller output, V) and, on the
    validation run, ``pulses`` (V, added after saturation). Meta: ``gtau`` (N/V), ``kp``, ``kv``.
    """
    import scipy.io

    try:
        data = scipy.io.loadmat(str(path))
    except Exception as exc:  # scipy raises several types for corrupt files
        raise InputError(f"{path}: not a readable MAT file ({exc})") from None
    missing = [k for k in _REQUIRED if k not in data]
    if missing:
        present = sorted(k for k in data if not k.startswith("__"))
        raise InputError(f"{path}: EMPS variable(s) {missing} missing; the file has {present}")
    col = lambda k: np.asarray(data[k], dtype=float).ravel()
    t, qm, vir = col("t"), col("qm"), col("vir")
    if qm.size == 0 or vir.size == 0:
        raise InputError(f"{path}: empty 'qm' or 'vir' array")
    if not (t.size == qm.size == vir.size):
        raise InputError(f"{path}: arrays differ in length: t {t.size}, qm {qm.size}, vir {vir.size}")
    gtau = float(col("gtau")[0])
    extras = {"qg": col("qg"), "vir": vir} if "qg" in data else {"vir": vir}
    if "pulses_N" in data:
        extras["pulses"] = col("pulses_N")
    meta = {"gtau": gtau}
    for k in ("kp", "kv"):
        if k in data:
            meta[k] = float(col(k)[0])
    return JointSeries(t=t, joints=[EMPS_JOINT], position=qm, effort=gtau * vir,
                       source=str(path), extras=extras, meta=meta)
