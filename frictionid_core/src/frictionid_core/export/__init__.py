"""A robot result handed over: a URDF, a MuJoCo model and a parameters YAML with the identified
inertials and friction (``frictionid export``; :mod:`.model_files`).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys(("export_data", "mujoco_text", "urdf_text", "yaml_text"), "frictionid_core.export.model_files"),
}

__all__ = ["export_data", "mujoco_text", "urdf_text", "yaml_text"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
