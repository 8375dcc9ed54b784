"""Node parameters: one validation shared with the requests; limits and paths read-only."""

from __future__ import annotations

import warnings

import pytest

with warnings.catch_warnings():
    warnings.simplefilter("ignore", DeprecationWarning)  # lark, via rosidl

from frictionid_core.errors import FrictionIdError
from frictionid_ros.config import LIMITS, PARAMETERS, PATH_PARAMETERS, make_config
from support.node_parts import node_config


def test_parameters_share_the_validation_and_name_the_parameter(tmp_path):
    assert node_config(tmp_path, friction_model="stribeck", seed=4).solve.friction == "stribeck"
    with pytest.raises(FrictionIdError, match=r"^parameter 'friction_model': unknown friction model 'lugre'; choose"):
        node_config(tmp_path, friction_model="lugre")
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
    for name in PATH_PARAMETERS + LIMITS:
        assert PARAMETERS[name][2], f"parameter '{name}' must be read-only"


def test_config_validation():
    defaults = {k: v[0] for k, v in PARAMETERS.items()}
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
