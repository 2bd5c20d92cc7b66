"""The packages of the wheel, found rather than listed (pyproject.toml holds everything else).

setuptools' ``packages.find`` cannot add a package whose folder lies elsewhere, and the bundled
scenes live in the top-level ``scenes/`` folder but install as ``simx_server.scenes``
(``[tool.setuptools.package-dir]``): so every package under the project's own top-level
packages is found here, and that one is added by name."""

from setuptools import find_packages, setup

setup(packages=[*find_packages(include=["simx_wire*", "simx_client*", "simx_server*", "simx_viewer*", "pyrep*"]),
                "simx_server.scenes"])
