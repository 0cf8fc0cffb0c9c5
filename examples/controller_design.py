"""Controller design for your joint: PI gains over a range of crossovers, margins, and robustness to inertia error.
================================================================================================================

For the control engineer tuning the velocity loop. Designs the discrete PI with python-control
(:func:`controllers.design_pi`) for each target crossover, prints gains, margins, closed-loop
bandwidth and step overshoot, and the phase margin that remains if the true inertia is half or
twice the design value. Optionally writes the Bode and step plots of one design.

    python examples/controller_design.py --J 4 --sigma 0 --crossovers 10 20 40 80
    python examples/controller_design.py --J 1.2 --sigma 6 --phase-margin 50 --plot 40 --out out/design
"""

from __future__ import annotations

import argparse
import warnings
from pathlib import Path

import control

from controllers.design.loop_analysis import analyse_design, plot_bode, plot_step
from controllers.design.pi import design_pi


def phase_margin_with_inertia(design, J_true: float) -> float:
    """Phase margin (deg) of the designed controller on a plant with inertia ``J_true`` (same sigma, ZOH)."""
    plant = control.sample_system(control.tf([1.0], [J_true, design.sigma]), design.Tc, method="zoh")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        _, pm, _, _ = control.margin(control.series(design.C, plant))
    return float(pm)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--J", type=float, default=4.0, help="inertia in kg·m² (default 4, the paper preset)")
    ap.add_argument("--sigma", type=float, default=0.0, help="viscous coefficient in N·m·s/rad (default 0)")
    ap.add_argument("--phase-margin", type=float, default=60.0, help="target phase margin in deg (default 60)")
    ap.add_argument("--Tc", type=float, default=1e-3, help="controller period in s (default 0.001)")
    ap.add_argument("--crossovers", type=float, nargs="+", default=[10.0, 20.0, 40.0, 80.0],
                    help="target crossovers in rad/s (default 10 20 40 80)")
    ap.add_argument("--plot", type=float, default=None, metavar="CROSSOVER",
                    help="write bode.png and step.png of the design at this crossover")
    ap.add_argument("--out", default="out/design", help="directory for --plot (default out/design)")
    args = ap.parse_args(argv)

    print(f"plant 1/(J s + sigma): J = {args.J:g} kg·m², sigma = {args.sigma:g} N·m·s/rad; Tc = {args.Tc:g} s; "
          f"target phase margin {args.phase_margin:g} deg")
    head = (f"{'wc [rad/s]':>10}{'Kp':>10}{'Ki':>11}{'PM [deg]':>10}{'GM [dB]':>9}{'BW [rad/s]':>12}"
            f"{'overshoot':>11}{'PM @ J/2':>10}{'PM @ 2J':>9}")
    print(head)
    print("-" * len(head))
    for wc in args.crossovers:
        d = design_pi(args.J, sigma=args.sigma, crossover=wc, phase_margin=args.phase_margin, Tc=args.Tc)
        a = analyse_design(d)
        gm_db = a.to_json_dict()["gain_margin_db"]
        print(f"{wc:>10g}{d.Kp:>10.4g}{d.Ki:>11.4g}{d.phase_margin:>10.2f}{gm_db:>9.1f}{a.bandwidth:>12.4g}"
              f"{a.overshoot:>10.1f}%{phase_margin_with_inertia(d, args.J / 2):>10.1f}"
              f"{phase_margin_with_inertia(d, 2 * args.J):>9.1f}")
    if args.plot is not None:
        d = design_pi(args.J, sigma=args.sigma, crossover=args.plot, phase_margin=args.phase_margin, Tc=args.Tc)
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        plot_bode(d).savefig(out / "bode.png", dpi=110)
        plot_step(analyse_design(d)).savefig(out / "step.png", dpi=110)
        print(f"figures: {out / 'bode.png'}, {out / 'step.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
