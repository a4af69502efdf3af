"""catkin_python_setup() entry: installs the bullet_floor_sim Python package from src/."""
from setuptools import setup
from catkin_pkg.python_setup import generate_distutils_setup

setup(**generate_distutils_setup(
    packages=[
        "bullet_floor_sim",
        "bullet_floor_sim.building",
        "bullet_floor_sim.data",
        "bullet_floor_sim.data.store",
        "bullet_floor_sim.data.trajectory",
        "bullet_floor_sim.gym",
        "bullet_floor_sim.mapping",
        "bullet_floor_sim.nav",
        "bullet_floor_sim.people",
        "bullet_floor_sim.people.crowd",
        "bullet_floor_sim.people.evaluation",
        "bullet_floor_sim.people.markov",
        "bullet_floor_sim.people.prediction",
        "bullet_floor_sim.people.tracking",
        "bullet_floor_sim.ros",
        "bullet_floor_sim.ros.sim",
        "bullet_floor_sim.sim", "bullet_floor_sim.sim.sensors",
    ],
    package_dir={"": "src"},
))
