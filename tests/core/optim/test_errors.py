"""frictionid_core.optim: bad requests fail with an OptimError that names the problem."""

from __future__ import annotations

import numpy as np
import pytest

from frictionid_core.errors import FrictionIdError, OptimError
from frictionid_core.optim import METHODS, Problem, minimize


def cost(X):
    return np.sum(X**2, axis=1)


def good_problem():
    return Problem(["Fc", "Fv"], [0.0, 0.0], [10.0, 5.0], cost)


def test_optim_error_is_a_frictionid_error():
    assert issubclass(OptimError, FrictionIdError)


def test_inverted_bounds_name_the_parameter():
    with pytest.raises(OptimError, match=r"parameter 'Fv': lower bound 6 is not below upper bound 5"):
        Problem(["Fc", "Fv"], [0.0, 6.0], [10.0, 5.0], cost)


def test_equal_bounds_rejected():
    with pytest.raises(OptimError, match=r"'Fc'.*lower bound 1 is not below upper bound 1"):
        Problem(["Fc"], [1.0], [1.0], cost)


def test_empty_bounds():
    with pytest.raises(OptimError, match="no parameters"):
        Problem([], [], [], cost)


def test_bounds_shape_mismatch():
    with pytest.raises(OptimError, match=r"2 parameter names \['Fc', 'Fv'\] but lower has 3 and upper has 2"):
        Problem(["Fc", "Fv"], [0.0, 0.0, 0.0], [1.0, 1.0], cost)


def test_non_finite_bound_names_parameter_and_side():
    with pytest.raises(OptimError, match=r"parameter 'Fv': upper bound inf is not finite"):
        Problem(["Fc", "Fv"], [0.0, 0.0], [1.0, np.inf], cost)
    with pytest.raises(OptimError, match=r"parameter 'Fc': lower bound nan is not finite"):
        Problem(["Fc", "Fv"], [np.nan, 0.0], [1.0, 1.0], cost)


def test_two_dimensional_bounds_rejected():
    with pytest.raises(OptimError, match=r"lower bounds must be a 1-D array, got shape \(1, 2\)"):
        Problem(["Fc", "Fv"], [[0.0, 0.0]], [1.0, 1.0], cost)


def test_duplicate_names():
    with pytest.raises(OptimError, match=r"duplicate parameter names: \['Fc'\]"):
        Problem(["Fc", "Fc"], [0.0, 0.0], [1.0, 1.0], cost)


def test_x0_outside_bounds_names_parameter():
    with pytest.raises(OptimError, match=r"parameter 'Fv': start value x0 = 7 is outside its bounds \[0, 5\]"):
        Problem(["Fc", "Fv"], [0.0, 0.0], [10.0, 5.0], cost, x0=[1.0, 7.0])


def test_bounds_checked_again_at_minimize():
    problem = good_problem()
    problem.upper = np.array([10.0, -1.0])  # mutated after construction
    with pytest.raises(OptimError, match=r"'Fv': lower bound 0 is not below upper bound -1"):
        minimize(problem, "de")


def test_unknown_method_lists_available():
    with pytest.raises(OptimError) as info:
        minimize(good_problem(), "simplex")
    message = str(info.value)
    assert "unknown optimiser 'simplex'" in message
    for name in METHODS:
        assert name in message


@pytest.mark.parametrize(
    ("method", "budget", "expected"),
    [
        ("de", {"generations": 0}, "de: generations must be positive, got 0"),
        ("pso", {"pop": 0}, "pso: pop must be positive, got 0"),
        ("ga", {"generations": -3}, "ga: generations must be positive, got -3"),
        ("aco", {"pop": -1}, "aco: pop must be positive, got -1"),
        ("bbo", {"generations": 2.5}, "bbo: generations must be a whole number, got 2.5"),
        ("de", {"pop": 3}, "de: pop must be at least 4, got 3"),
        ("bo", {"calls": 0}, "bo: calls must be positive, got 0"),
        ("dt", {"calls": -5}, "dt: calls must be positive, got -5"),
        ("lm", {"calls": 0}, "lm: calls must be positive, got 0"),
        ("hybrid", {"generations": 0}, "de: generations must be positive, got 0"),
    ],
)
def test_bad_budget(method, budget, expected):
    with pytest.raises(OptimError, match=expected.replace(".", r"\.")):
        minimize(good_problem(), method, **budget)


def test_unknown_option_lists_accepted():
    with pytest.raises(OptimError, match=r"de: unknown option\(s\) \['FF'\]; it accepts \[.*'CR'.*'F'"):
        minimize(good_problem(), "de", FF=0.5)


@pytest.mark.parametrize(
    ("method", "options", "expected"),
    [
        ("de", {"CR": 1.5}, "de: CR must be a number in [0, 1], got 1.5"),
        ("pso", {"topology": "star"}, "pso: topology must be one of ('nearest', 'ring'), got 'star'"),
        ("ga", {"elites": 60}, "ga: elites must be a whole number in [0, pop - 2 = 48], got 60"),
        ("ga", {"selection": "rank"}, "ga: selection must be one of ('roulette', 'tournament'), got 'rank'"),
        ("bo", {"acq_func": "UCB"}, "bo: acq_func must be one of"),
        ("dt", {"base_estimator": "GBRT"}, "dt: base_estimator must be one of ('ET', 'RF'), got 'GBRT'"),
        ("dt", {"n_points": 0}, "dt: n_points must be positive, got 0"),
        ("hybrid", {"global_method": "lm"}, "hybrid: global_method must be one of"),
    ],
)
def test_bad_method_option(method, options, expected):
    with pytest.raises(OptimError) as info:
        minimize(good_problem(), method, **options)
    assert expected in str(info.value)


def test_batch_cost_wrong_shape():
    problem = Problem(["Fc", "Fv"], [0.0, 0.0], [1.0, 1.0], lambda X: np.zeros(3))
    with pytest.raises(OptimError, match=r"de: batch_cost returned shape \(3,\) for a population of 50"):
        minimize(problem, "de")


def test_problem_type_checked():
    with pytest.raises(OptimError, match="minimize needs a Problem, got dict"):
        minimize({"names": ["a"]}, "de")


def test_batch_residuals_need_residuals():
    with pytest.raises(OptimError, match="batch_residuals must be callable and come with residuals"):
        Problem(["Fc", "Fv"], [0.0, 0.0], [10.0, 5.0], cost, batch_residuals=lambda P: P)
