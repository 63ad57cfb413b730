"""The scenario catalogue (envs/) and the MJCF models and textures (assets/) live at the top
of the checkout, as the design card wants; the wheel carries them inside the package as
lgmd_sim/_data/envs and lgmd_sim/_data/assets (see lgmd_sim/core/resources.py)."""

from setuptools import find_packages, setup

setup(
    packages=[
        *find_packages(include=["lgmd_sim", "lgmd_sim.*"]),
        "lgmd_sim._data.envs",
        "lgmd_sim._data.assets",
    ],
    package_dir={"lgmd_sim._data.envs": "envs", "lgmd_sim._data.assets": "assets"},
)
