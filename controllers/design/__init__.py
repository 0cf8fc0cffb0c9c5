"""Velocity-loop design: discrete PI tuning and loop analysis with python-control."""
