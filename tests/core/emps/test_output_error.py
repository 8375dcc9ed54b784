"""Output-error identification of the EMPS (simulator inside the optimiser)."""

import json

import pytest

from frictionid_core.emps import EmpsSimulator, identify_output_error, load_emps
from frictionid_core.identification import IdentifyRequest, IdentifyResult
from support.data import EMPS_ESTIMATION, EMPS_VALIDATION


@pytest.fixture(scope="module")
def oe_coulomb_asym():
    return identify_output_error(EMPS_ESTIMATION, IdentifyRequest(friction="coulomb", asymmetric=True, solver="lm"))


@pytest.mark.slow
def test_output_error_improves_the_simulated_position(oe_coulomb_asym):
    res = oe_coulomb_asym
    idm = res.idm_params
    est = EmpsSimulator(load_emps(EMPS_ESTIMATION), "coulomb", True, substeps=4)
    before = est.position_relerr(est.as_array(idm))[0]
    assert res.metrics["position_relerr_pct"] < before
    assert res.metrics["clock"] == "true"
    d = res.to_dict()  # the output-error keys after those of every result, and the round trip
    assert list(d)[-4:] == ["output_error", "idm", "idm_params", "request"] and d["optimizer"]["method"] == "lm"
    assert IdentifyResult.from_dict(json.loads(json.dumps(d))) == res


@pytest.mark.slow
def test_output_error_generalises_to_the_validation_run(oe_coulomb_asym):
    """Validation, true clock: IDM Coulomb-asymmetric 0.002444 %; output error must do better
    (measured 0.002391 %; the issue quotes about 0.00248 % for this pipeline)."""
    val = EmpsSimulator(load_emps(EMPS_VALIDATION), "coulomb", True)
    oe = val.position_relerr(val.as_array(oe_coulomb_asym.params))[0]
    idm = val.position_relerr(val.as_array(oe_coulomb_asym.idm_params))[0]
    assert oe < idm
    assert oe <= 0.00248
