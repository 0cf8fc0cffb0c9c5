"""The C core's build: everything else is in pyproject.toml. setuptools runs the three cffi build scripts
(one extension module per layer, see plant/_cbuild.py) at ``pip install``."""
from setuptools import setup

setup(cffi_modules=[
    "plant/_cbuild.py:ffibuilder",
    "adaptive_ff/_cbuild.py:ffibuilder",
    "controllers/_cbuild.py:ffibuilder",
])
