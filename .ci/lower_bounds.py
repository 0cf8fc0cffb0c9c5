"""Print a pip constraints file pinning every runtime dependency of pyproject.toml to its lower bound.

Used by .ci/run's lower-bounds job: ``python .ci/lower_bounds.py > lower.txt`` then
``pip install -c lower.txt -e '.[test]'``. Each ``name>=X`` of ``[project].dependencies`` becomes
``name==X`` (extras dropped: the constraint is on the distribution); a dependency without a lower
bound is an error, so a new dependency cannot slip in untested at its floor.
"""

import re
import sys
import tomllib
from pathlib import Path


def lower_bounds(pyproject: Path) -> list[str]:
    """``name==version`` lines for the ``>=`` bounds of ``[project].dependencies`` of ``pyproject``."""
    deps = tomllib.loads(pyproject.read_text())["project"]["dependencies"]
    out = []
    for dep in deps:
        m = re.fullmatch(r"\s*([A-Za-z0-9_.-]+)(\[[^\]]*\])?\s*>=\s*([0-9][0-9A-Za-z.]*)\s*(,.*)?", dep)
        if m is None:
            raise SystemExit(f"{pyproject}: dependency {dep!r} has no '>=' lower bound")
        out.append(f"{m.group(1)}=={m.group(3)}")
    return out


if __name__ == "__main__":
    root = Path(__file__).resolve().parents[1]
    print("\n".join(lower_bounds(root / "pyproject.toml")))
    sys.exit(0)
