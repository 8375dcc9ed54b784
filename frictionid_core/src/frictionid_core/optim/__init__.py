"""The optimiser suite: one module per method behind one call, :func:`minimize`.

    >>> result = minimize(problem, "de", seed=1)            # thesis defaults
    >>> result = minimize(problem, "pso", pop=30, generations=60, topology="ring")

Methods (docs/reference.md#optimisers; thesis settings are each module's defaults):

=========  ============================================================  ==============
id         method                                                        budget
=========  ============================================================  ==============
ga         real-coded genetic algorithm                                  pop, generations
aco        ant colony optimisation for continuous domains (ACO_R)       pop, generations
bbo        biogeography-based optimisation                               pop, generations
de         differential evolution rand/1/bin                             pop, generations
pso        particle swarm, local neighbourhood                           pop, generations
lm         bounded nonlinear least squares (trust-region reflective)     calls
bo         Bayesian optimisation, Gaussian process (skopt gp_minimize)   calls
dt         sequential decision trees (skopt forest_minimize, ET)         calls
hybrid     a global method (default de) then an lm polish                pop, generations, calls
=========  ============================================================  ==============

Every method is seeded through one ``numpy.random.Generator`` (same seed -> identical
result), keeps every point inside the bounds, treats NaN/inf costs as the worst cost
(counted in ``n_nan``) and records f_min / dist_mean histories (thesis eq. 2-17, 2-18).
Population methods evaluate each generation with a single ``batch_cost`` call.
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys(("OptimResult", "Problem"), "frictionid_core.optim.problem"),
    **dict.fromkeys((
        "BUDGETS", "call_method", "CALL_METHODS", "METHOD_IDS", "method_options", "METHODS", "minimize",
        "POPULATION_METHODS", "SOLVERS",
    ), "frictionid_core.optim.suite"),
}

__all__ = ["BUDGETS", "CALL_METHODS", "METHODS", "METHOD_IDS", "OptimResult", "POPULATION_METHODS", "Problem",
           "SOLVERS", "call_method", "method_options", "minimize"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
