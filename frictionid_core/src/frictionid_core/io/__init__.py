"""Loaders: every source becomes one :class:`~frictionid_core.timeseries.JointSeries` (:func:`load`,
:mod:`.loader`; readers: :mod:`.mat`, :mod:`.csv`, :mod:`.layout`, :mod:`.bag`, :mod:`.cdr`).

Also public: the checks of a series (:func:`check_series`, :func:`stamp_gaps`, ``MIN_SAMPLES``), the
alignment of a separate effort stream (:func:`align_effort`), the bag helpers of other readers
(:func:`open_reader`, :func:`joint_state_topic`, :func:`topic_listing`, :func:`first_bag_stamp`, the
message type names ``JOINT_STATE`` and ``FLOAT_ARRAY``) and writers of test data
(:func:`write_joint_state_bag`, :func:`save_csv`). rosbags is imported when a bag is opened.
"""

from frictionid_core import lazy

# Public names -> the module that defines them (loaded on first use).
_LAZY = {
    **dict.fromkeys(("align_effort",), "frictionid_core.io.align"),
    **dict.fromkeys((
        "first_bag_stamp", "FLOAT_ARRAY", "JOINT_STATE", "joint_state_topic", "list_topics", "load_bag",
        "open_reader", "topic_listing", "write_joint_state_bag",
    ), "frictionid_core.io.bag"),
    **dict.fromkeys(("check_series", "MIN_SAMPLES", "stamp_gaps"), "frictionid_core.io.checks"),
    **dict.fromkeys(("read_table", "save_csv"), "frictionid_core.io.csv"),
    **dict.fromkeys(("Layout", "load_layout"), "frictionid_core.io.layout"),
    **dict.fromkeys(("BAG_SUFFIXES", "load"), "frictionid_core.io.loader"),
    **dict.fromkeys(("load_emps_mat",), "frictionid_core.io.mat"),
}

__all__ = ["BAG_SUFFIXES", "FLOAT_ARRAY", "JOINT_STATE", "Layout", "MIN_SAMPLES", "align_effort", "check_series",
           "first_bag_stamp", "joint_state_topic", "list_topics", "load", "load_bag", "load_emps_mat", "load_layout",
           "open_reader", "read_table", "save_csv", "stamp_gaps", "topic_listing", "write_joint_state_bag"]

__getattr__, __dir__ = lazy.lazy_names(__name__, _LAZY)
