"""Node parameters: one validation shared with the requests; limits and paths read-only; every
declared range and choice enforced; the YAML defaults and the docs table agree with the declarations."""

from __future__ import annotations

import math
import re
import warnings

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl

from frictionid_core import FrictionIdError
from frictionid_ros.parameters import (
    PAGE,
    PARAMETERS,
    TABLE_END,
    TABLE_START,
    YAML_FILE,
    defaults_yaml,
    make_config,
    markdown_table,
)
from support.node_parts import node_config

# What a client on the ROS domain may change at runtime (docs/node.md, "Security"); every
# other parameter, among them every file or folder and every limit, is set at start-up only.
RUNTIME = {"friction_model", "asymmetric", "solver", "seed", "consistent", "prior_weight", "window_seconds",
           "min_samples", "max_missing_pct", "smoothing_eps"}
PATHS_AND_LIMITS = ("system", "results_file", "results_dir", "max_budget", "max_population", "max_window_seconds",
                    "max_wall_s", "worker_nice")


def test_parameters_share_the_validation_and_name_the_parameter(tmp_path):
    assert node_config(tmp_path, friction_model="stribeck", seed=4).solve.friction == "stribeck"
    with pytest.raises(FrictionIdError, match=r"^parameter 'friction_model': unknown friction model 'dahl'; choose"):
        node_config(tmp_path, friction_model="dahl")
    with pytest.raises(FrictionIdError, match=r"^parameter 'solver': unknown solver 'x'"):
        node_config(tmp_path, solver="x")
    with pytest.raises(FrictionIdError, match=r"^parameter 'window_seconds' = 90.0 s is over the limit "
                                              r"max_window_seconds = 60.0 s"):
        node_config(tmp_path, window_seconds=90.0)
    with pytest.raises(FrictionIdError, match=r"^parameter 'worker_nice' must lie in 0..19, got 20"):
        node_config(tmp_path, worker_nice=20)
    assert node_config(tmp_path).results_dir == tmp_path  # the folder of results_file by default
    assert node_config(tmp_path, results_dir=str(tmp_path / "r")).results_dir == tmp_path / "r"


def test_paths_and_limits_are_start_up_parameters():
    """A client's runtime parameter change can name no file and lift no limit."""
    for name in PATHS_AND_LIMITS:
        assert PARAMETERS[name].read_only, f"parameter '{name}' must be read-only"
    assert {name for name, p in PARAMETERS.items() if not p.read_only} == RUNTIME


def test_config_validation():
    defaults = {name: p.default for name, p in PARAMETERS.items()}
    assert make_config(defaults).capacity == 30001
    for change, needle in [({"system": "scara"}, "scara"), ({"solver": "x"}, "solver"),
                           ({"qos": "fast"}, "qos"), ({"buffer_seconds": 0.0}, "buffer_seconds"),
                           ({"joints": ["a", "a"]}, "duplicated"),
                           ({"realtime_priority": "fast"}, "realtime_priority' must be auto, off or a priority"),
                           ({"realtime_priority": 100}, "realtime_priority"),
                           ({"realtime_priority": 10.0}, "realtime_priority")]:
        with pytest.raises(FrictionIdError, match=needle):
            make_config({**defaults, **change})
    # realtime_priority: a string or an integer (YAML 20 or "20")
    for value, want in (("auto", "auto"), ("off", 0), (0, 0), (20, 20), ("20", 20)):
        assert make_config({**defaults, "realtime_priority": value}).realtime_priority == want


def _outside(p, bound: float, direction: int):
    """A value beyond ``bound`` (or the bound itself when the bounds are exclusive)."""
    if p.exclusive:
        return bound
    return bound + direction * (1 if isinstance(p.default, int) else 0.5)


def test_every_declared_range_and_choice_is_enforced_in_one_line_naming_the_parameter():
    bounded = {name: p for name, p in PARAMETERS.items() if p.low is not None or p.high is not None}
    assert len(bounded) >= 20
    for name, p in bounded.items():
        refused = [_outside(p, bound, d) for bound, d in ((p.low, -1), (p.high, 1)) if bound is not None]
        if isinstance(p.default, float):
            refused.append(math.nan)
        for value in refused:
            with pytest.raises(FrictionIdError) as e:
                make_config({name: value})
            verb = "lie in" if p.low is not None and p.high is not None else "be"
            assert re.fullmatch(rf"parameter '{name}' must {verb} {re.escape(p.rule)}, got {value}", str(e.value))
        if not p.exclusive:  # the bounds themselves are allowed
            for bound in (p.low, p.high):
                if bound is not None:
                    assert getattr(make_config({name: type(p.default)(bound)}), name) == bound
    choices = {name: p for name, p in PARAMETERS.items() if p.choices}
    assert set(choices) == {"friction_model", "solver", "input_executor", "identification_worker", "qos",
                            "effort_topic_type", "velocity_source"}
    for name, p in choices.items():
        with pytest.raises(FrictionIdError, match=rf"^parameter '{name}': unknown .* 'x'; choose one of "
                                                  rf"{re.escape(', '.join(p.choices))}$"):
            make_config({name: "x"})
        assert all(getattr(make_config({name: c, "reference_topic": "r"}), name) == c for c in p.choices)
    with pytest.raises(FrictionIdError, match=r"^parameter 'buffer_seconds' must be a float, got 'long'$"):
        make_config({"buffer_seconds": "long"})


def test_checks_across_parameters():
    with pytest.raises(FrictionIdError, match=r"^buffer_seconds \* max_rate_hz = 60000000 samples is too large"):
        make_config({"buffer_seconds": 60.0, "max_rate_hz": 1e6})
    with pytest.raises(FrictionIdError, match=r"^velocity_source 'reference' needs a reference_topic$"):
        make_config({"velocity_source": "reference", "reference_topic": ""})
    cfg = make_config({"results_file": "/tmp/x/p.json"})
    assert cfg.results_file == cfg.results_dir / "p.json"


def test_yaml_defaults_and_docs_table_are_written_from_the_declarations():
    """Regenerate with ``python -m frictionid_ros.parameters`` after changing a declaration."""
    assert YAML_FILE.read_text(encoding="utf-8") == defaults_yaml()
    page = PAGE.read_text(encoding="utf-8")
    table = page.split(TABLE_START + "\n", 1)[1].split(TABLE_END, 1)[0]
    assert table == markdown_table()
    rows = [line for line in table.splitlines() if line.startswith("| `")]
    assert [row.split("`")[1] for row in rows] == list(PARAMETERS)
    assert "| `worker_nice` | integer | `19` |  | 0..19 |  |" in table
    assert "| `window_seconds` | double | `0.0` | s | >= 0 | yes |" in table
