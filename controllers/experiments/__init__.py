"""Experiments built on the engine: the mode comparison (main job), quasi-static runs, synthetic logs, the paper's figures and sweeps."""
