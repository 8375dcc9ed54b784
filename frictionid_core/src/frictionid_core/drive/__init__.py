"""Drives between a log and the model's joints: gear ratios, coupling and effort units
(:class:`Drive`, :mod:`.transmission`); bundled drives in ``bundled/<name>.yaml`` (``tx40``).
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys((
        "bundled_drives", "Drive", "drive_from_dict", "friction_rows", "load_drive", "result_drive",
    ), "frictionid_core.drive.transmission"),
}

__all__ = ["Drive", "bundled_drives", "drive_from_dict", "friction_rows", "load_drive", "result_drive"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
