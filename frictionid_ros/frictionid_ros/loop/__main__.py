"""``python -m frictionid_ros.loop``: ``frictionid loop`` (:func:`.loop_command.main`)."""

import sys

from frictionid_ros.loop.loop_command import main

if __name__ == "__main__":
    sys.exit(main())
