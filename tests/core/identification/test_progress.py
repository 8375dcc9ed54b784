"""The optimisers' progress hook (``identify(..., progress=...)``): what it reports and how a
caller stops a run with it (the node's cancel and wall-time limit)."""

from __future__ import annotations

import numpy as np
import pytest

from frictionid_core.identification import IdentifyRequest, SolverOptions, identify


class Stop(Exception):
    pass


def test_population_method_reports_every_generation(synthetic):
    calls = []
    search = SolverOptions("de", seed=3, pop=12, generations=8, varpro=False)  # every parameter: no polish
    request = IdentifyRequest(friction="tustin", solver=search)
    res = identify(synthetic(), request, progress=lambda *a: calls.append(a))
    gens, evals, best = (np.array(c) for c in zip(*calls))
    assert list(gens) == list(range(1, 9)) and list(evals) == [12 * g for g in range(1, 9)]
    assert np.all(np.diff(best) <= 0)  # best so far never worsens
    opt = res.optimizer
    assert best[-1] == opt["fun"] and list(best) == opt["history_fmin"]


def test_the_polish_of_a_shape_search_continues_its_count(synthetic):
    """With variable projection (the default for a law with a dip) the search's best point is
    polished by lm: its calls report on at the search's last generation, the evaluations and the
    best so far still never going back."""
    calls = []
    request = IdentifyRequest(friction="tustin", solver=SolverOptions("de", seed=3, pop=12, generations=8))
    res = identify(synthetic(), request, progress=lambda *a: calls.append(a))
    gens, evals, best = (np.array(c) for c in zip(*calls))
    assert list(gens[:8]) == list(range(1, 9)) and set(gens[8:]) == {8} and len(gens) > 8
    assert np.all(np.diff(evals) > 0) and np.all(np.diff(best) <= 0)
    assert res.varpro and "polished by lm" in res.optimizer["message"]
    assert best[-1] == pytest.approx(res.optimizer["fun"], rel=1e-9)


def test_call_methods_report_every_call(synthetic):
    calls = []
    res = identify(synthetic(), IdentifyRequest(friction="tustin", solver="lm"), progress=lambda *a: calls.append(a))
    assert {c[0] for c in calls} == {0}  # no generations
    opt = res.optimizer
    assert [c[1] for c in calls] == list(range(1, len(calls) + 1))
    assert [c[2] for c in calls] == opt["history_fmin"]  # one per logged call (lm's final re-evaluation is not)
    assert calls[-1][2] == pytest.approx(opt["fun"], rel=1e-9)


def test_an_exception_in_progress_ends_the_run(synthetic):
    seen = []

    def stop_at_third(generation, evaluations, best):
        seen.append(generation)
        if generation == 3:
            raise Stop

    with pytest.raises(Stop):
        identify(synthetic(), IdentifyRequest(friction="tustin", solver=SolverOptions("de", pop=12, generations=50)),
                 progress=stop_at_third)
    assert seen == [1, 2, 3]


def test_least_squares_has_no_progress(synthetic):
    calls = []
    identify(synthetic(), IdentifyRequest(solver="ls"), progress=lambda *a: calls.append(a))
    assert calls == []
