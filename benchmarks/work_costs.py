"""Measure the per-unit costs behind the commands' work estimates (controllers.cli.budget.COSTS) on this machine.

Run:  python benchmarks/work_costs.py [--quick]

Times each unit of work twice at two sizes (the slope is the cost per unit, the intercept the fixed part) and
prints the measured value beside the one in ``COSTS``: a closed-loop run per sample and mode, a comparison's
preparation per sample, ``design``'s step response per sample, ``paper-figures``' simulation, experiment and
quasi-static speeds, the eq. 4 / sliding fit and its bootstrap refits per sample, an output-error and a
closed-loop fit per sample and a fit of ``identify --form``. ``--quick`` skips the output-error, closed-loop and
form fits (minutes on 2 cores).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import sys
import tempfile
import time
from pathlib import Path

ROBOT = ["--columns", "t=time_ms,u=current_A,w=velocity_deg_s", "--time-unit", "ms", "--velocity-unit", "deg/s",
         "--current-to-torque", "60", "--Vs", "0.02", "--delta", "1", "--quiet", "--yes"]


def _timed(fn) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def _cli(argv) -> float:
    from controllers.cli.main import main

    def run():
        with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
            status = main(argv)
        if status != 0:
            raise SystemExit(f"{argv}: exit status {status}")

    return _timed(run)


def _slope(f, a: float, b: float) -> tuple[float, float]:
    """``(slope, intercept)`` of the time ``f(x)`` between ``x = a`` and ``x = b``."""
    ta, tb = f(a), f(b)
    slope = (tb - ta) / (b - a)
    return slope, ta - slope * a


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="skip the output-error, closed-loop and form fits")
    args = ap.parse_args(argv)

    from controllers import compare
    from controllers.cli.budget import COSTS
    from controllers.design.loop_analysis import analyse_design
    from controllers.design.pi import design_pi
    from controllers.experiments.paper_figures import PaperFigureOptions, paper_figures
    from plant import preset

    p = preset("paper")
    found = {}
    from controllers.simulation.compensators import MODES

    one, all_modes = ("none",), MODES
    compare(p, duration=10.0, modes=all_modes, progress=False)  # warm: first calls initialise the C core
    loop, _ = _slope(lambda d: _timed(lambda: compare(p, duration=d, modes=one, progress=False)), 300.0, 1500.0)
    found["loop"] = loop / 1e3 / 2  # per sample (1 kHz) and run: none and frictionless
    full, fixed = _slope(lambda d: _timed(lambda: compare(p, duration=d, modes=all_modes, progress=False)), 300.0,
                         1500.0)
    found["prepare"] = max(full / 1e3 - 8 * found["loop"], 0.0)
    found["compare_fixed"] = fixed
    d = design_pi(4.0, sigma=40.0, crossover=20.0, phase_margin=60.0, Tc=1e-3)
    step, _ = _slope(lambda t: _timed(lambda: analyse_design(d, t_end=t)), 20.0, 80.0)
    found["step"] = step / 1e3
    with tempfile.TemporaryDirectory() as tmp:
        def pf(**kw):
            return _timed(lambda: paper_figures(Path(tmp) / "pf", options=PaperFigureOptions(**kw), progress=False))

        found["paper_sim"] = _slope(lambda s: pf(sim_duration=s), 30.0, 150.0)[0] / 1e3
        found["paper_exp"] = _slope(lambda s: pf(exp_duration=s), 60.0, 180.0)[0] / 1e3
        found["paper_speed"] = _slope(lambda k: pf(n_speeds=int(k)), 10.0, 30.0)[0]
        paper_figures(Path(tmp) / "logs", save_data=True, progress=False)
        ctl = str(Path(tmp) / "logs" / "controller_log.csv")
        robot = str(Path(tmp) / "logs" / "robot_log.csv")
        n_ctl = sum(1 for _ in open(ctl)) - 2
        n_rob = sum(1 for _ in open(robot)) - 2
        t0 = _cli(["identify", ctl, *ROBOT, "--bootstrap", "0"])
        found["eq4"] = t0 / n_ctl
        found["linear_refit"] = (_cli(["identify", ctl, *ROBOT, "--bootstrap", "2000"]) - t0) / (1998 * n_ctl)
        if not args.quick:
            found["output_error"] = _cli(["identify", robot, *ROBOT, "--method", "output_error", "--bootstrap",
                                          "0"]) / n_rob
            ref = ["--reference-column", "reference_deg_s", "--controller", str(Path(tmp) / "logs" / "controller.json")]
            found["closed_loop"] = _cli(["identify", robot, *ROBOT, *ref, "--method", "closed_loop", "--bootstrap",
                                         "0"]) / n_rob
            found["form"] = _cli(["identify", robot, *ROBOT, "--form", "auto", "--folds", "2"]) / (n_rob * 6 * 3)
    print(f"{'cost':<16}{'measured':>12}{'COSTS':>12}")
    for k, v in found.items():
        print(f"{k:<16}{v:>12.3g}{COSTS[k]:>12.3g}")
    print(json.dumps({k: float(f"{v:.3g}") for k, v in found.items()}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
