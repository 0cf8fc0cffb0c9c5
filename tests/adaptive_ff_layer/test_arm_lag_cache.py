"""The cache of benchmarks/arm_lag.py: it keeps each arm's joints with the settings they were run at and gives back
only the arms run at the settings asked for, so that a cache never changes a result."""

import json

import pytest

pytest.importorskip("pinocchio", reason="the [arm] extra is not installed: pip install -e '.[arm]'")

from benchmarks import arm_lag  # noqa: E402


def _row(seed: int, joint: str, tau: float) -> dict:
    return {"seed": seed, "joint": joint, "true": 0.0, "tau": tau, "lo": None, "hi": None, "reason": None, "info": {}}


def test_cache_gives_back_the_arms_of_the_settings_asked_for(tmp_path):
    path = tmp_path / "cache.jsonl"
    fine = {"duration": 20.0, "n_lag": 10, "kind": "example", "stop_refine": 10, "refine_stops": False}
    coarse = {**fine, "stop_refine": 1}
    arm_lag.collect([(0, [_row(0, "shoulder", 0.004), _row(0, "elbow", 0.0)])], {}, path, fine)
    arm_lag.collect([(0, [_row(0, "shoulder", 0.007)]), (1, [_row(1, "shoulder", 0.002)])], {}, path, coarse)
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert [r["settings"] for r in lines] == [fine, fine, coarse, coarse]
    assert arm_lag.read_cache(path, fine) == {0: [{**_row(0, "shoulder", 0.004), "settings": fine},
                                                   {**_row(0, "elbow", 0.0), "settings": fine}]}
    got = arm_lag.read_cache(path, coarse)
    assert sorted(got) == [0, 1] and got[0][0]["tau"] == 0.007 and got[1][0]["tau"] == 0.002
    assert arm_lag.read_cache(path, {**fine, "refine_stops": True}) == {}
    assert arm_lag.read_cache(tmp_path / "absent.jsonl", fine) == {} and arm_lag.read_cache(None, fine) == {}


def test_cache_without_settings_is_not_read(tmp_path):
    """A row written before the settings were kept (no ``settings``) is run again, not read."""
    path = tmp_path / "old.jsonl"
    path.write_text(json.dumps(_row(3, "wrist", 0.005)) + "\n")
    assert arm_lag.read_cache(path, {"duration": 20.0, "n_lag": 10, "kind": "example", "stop_refine": 10,
                                      "refine_stops": False}) == {}
