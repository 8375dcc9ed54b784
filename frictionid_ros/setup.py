from glob import glob

from setuptools import find_packages, setup

package_name = "frictionid_ros"

setup(
    name=package_name,
    version="0.1.0",
    packages=find_packages(exclude=["test"]),
    data_files=[
        ("share/ament_index/resource_index/packages", ["resource/" + package_name]),
        ("share/" + package_name, ["package.xml"]),
        ("share/" + package_name + "/config", glob("config/*.yaml")),
    ],
    # frictionid-core: the pure-Python core of this repository (make setup installs both with --no-deps)
    install_requires=["setuptools", "frictionid-core"],
    zip_safe=True,
    maintainer="frictionid developers",
    maintainer_email="dev@frictionid.invalid",
    description="ROS 2 node wrapping frictionid_core",
    license="Apache-2.0",
    entry_points={
        "console_scripts": ["frictionid_node = frictionid_ros.node.frictionid_node:main",
                            "frictionid_sim = frictionid_ros.loop.sim_node:main",
                            "frictionid_loop_controller = frictionid_ros.loop.controller_node:main",
                            "frictionid_loop = frictionid_ros.loop.loop_command:main"],
        "frictionid.commands": ["replay = frictionid_ros.replay:register",
                                "loop = frictionid_ros.loop.loop_command:register",
                                "experiment = frictionid_ros.loop.experiment_command:register"],
    },
)
