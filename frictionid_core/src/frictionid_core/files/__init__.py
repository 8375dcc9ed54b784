"""Files: written atomically (:mod:`.writing`: JSON, text, bytes) and read with one clear line per
problem (:mod:`.reading`: result files in JSON or YAML, user YAML files and their checks).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys((
        "check_keys", "joint_names", "read_json", "read_yaml", "YAML_SUFFIXES",
    ), "frictionid_core.files.reading"),
    **dict.fromkeys((
        "remove_orphans", "temporary_name", "write_bytes", "write_json", "write_text",
    ), "frictionid_core.files.writing"),
}

__all__ = ["YAML_SUFFIXES", "check_keys", "joint_names", "read_json", "read_yaml", "remove_orphans", "temporary_name",
           "write_bytes", "write_json", "write_text"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
