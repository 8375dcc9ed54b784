"""``python -m frictionid_ros.node``: run the frictionid node (:func:`.frictionid_node.main`)."""

import sys

from frictionid_ros.node.frictionid_node import main

if __name__ == "__main__":
    sys.exit(main())
