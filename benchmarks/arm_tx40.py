"""A real arm: the Staubli TX40 log of thanhndv212/figaroh-examples identified by ``identify-arm``.

Run:  python -m benchmarks.arm_tx40 [--bootstrap 200] [--seed 0] [--no-figaroh] [--rows moving|sliding]

The log (``data/tx40/``: 45 000 samples at 5 kHz of the six motor angles and motor torques, the URDF and the
transmission: ratios, the wrist coupling of joints 5 and 6, the joint 2 and 3 offsets) goes through
:func:`adaptive_ff.arm.fit.identify_arm` as ``adaptive-ff identify-arm`` runs it. Printed per joint: the package's
viscous ``sigma`` and Coulomb ``Fc`` with their 95 % intervals, beside

- the reference values of that repository, ``fv`` and ``fs`` of ``identification.robot_params`` in
  ``examples/staubli_TX40/config/TX40_config.yaml`` (the ``standard_parameter`` values its scripts plot as
  "CAD"; the coupled wrist adds ``fvm6``, ``fsm6`` for the motor of joint 6, listed under the table);
- FIGAROH's IDIM-LS on the same log: the steps of that repository's ``examples/staubli_TX40/identification.py``
  replayed here with NumPy, SciPy and Pinocchio (FIGAROH itself is not a dependency): the motor angles through
  ``inv(red_q)``, FIGAROH's ``low_pass_filter_data`` (4th-order Butterworth, ``Wn = ts * 100 / 2``, filtfilt,
  20 samples cut at both ends), the joint 2 and 3 offsets, FIGAROH's forward-difference velocity and its gradient,
  the regressor with ``Ia, fv, fs, offset`` per joint and ``add_coupling_TX40``'s three columns (``Iam6, fvm6,
  fsm6``), ``red_tau`` on the motor torques, ``signal.decimate`` by 10 twice per joint, the rows slower than
  ``dq_lim_def`` left out, columns of squared norm below 0.001 dropped, ordinary least squares; the ``±`` is
  FIGAROH's ``relative_stdev`` (the covariance's standard deviation, in % of the value).

Then each joint's friction lag and velocity noise, and the CPU and wall time of the package's identification (the
URDF, the log, the fit, the 200-refit bootstrap, the lag fits), and of the same with ``--no-lag``.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np

from adaptive_ff.arm.rows import DEFAULT_ROWS, ROWS

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "data" / "tx40"
LOG, URDF, TRANSMISSION = DATA / "tx40_motor.npz", DATA / "tx40.urdf", DATA / "transmission.toml"

#: ``identification.robot_params`` of examples/staubli_TX40/config/TX40_config.yaml (figaroh-examples).
REFERENCE = {
    "fv": (8.05, 5.53, 1.97, 1.11, 1.86, 0.65),
    "fs": (7.14, 8.26, 6.34, 2.48, 3.03, 0.282),
    "offset": (0.392, 1.37, 0.326, -0.102, -0.0288, 0.127),
    "Iam6": 0.00964, "fvm6": 0.616, "fsm6": 1.95,
}
#: The cutoff (Hz) of identify-arm's zero-phase low-pass on this log (the default, 20 Hz, is for slower logs: the
#: page shows both).
CUTOFF_ARM = 80.0
#: FIGAROH's settings of the same file: reduction ratios, sample time, cutoff, the speeds below which rows go.
RATIO = (32.0, 32.0, 45.0, -48.0, 45.0, 32.0)
TS, CUTOFF = 0.0002, 100.0
DQ_LIM = (0.05009095, 0.05009095, 0.07504916, 0.0715585, 0.05585054, 0.12217305)


def identify(bootstrap: int = 200, seed: int = 0, cutoff: float = CUTOFF_ARM, progress: bool | None = None,
             motor6_removed: bool = False, lag: bool = True, rows: str | None = None):
    """``(ArmIdentification, cpu s, wall s)`` of the TX40 log as ``adaptive-ff identify-arm --cutoff CUTOFF``
    runs it; ``motor6_removed``: the reference values' terms of the motor of joint 6 (``Iam6, fvm6, fsm6`` on
    ``ddq5 + ddq6``, ``dq5 + dq6``, ``sgn(dq5 + dq6)``) subtracted from the torques of joints 5 and 6 first;
    ``lag``: with the friction lag fits (``identify-arm``'s default; False: ``--no-lag``); ``rows``: identify_arm's
    (``--rows``; None: its default)."""
    from adaptive_ff.arm.arm_log import read_arm_log
    from adaptive_ff.arm.fit import identify_arm
    from adaptive_ff.arm.robot import load_urdf
    from adaptive_ff.arm.transmission import read_transmission

    c0, w0 = _cpu(), time.perf_counter()
    arm = load_urdf(URDF)
    gear = read_transmission(TRANSMISSION, arm.n)
    log = gear.to_joint(read_arm_log(LOG, arm.n, joint_names=arm.names))
    if motor6_removed:
        log = _without_motor6(log, cutoff)
    res = gear.with_coupling_warnings(identify_arm(log, arm, cutoff=cutoff, n_bootstrap=bootstrap, seed=seed,
                                                   progress=progress, lag=lag,
                                                   **({} if rows is None else {"rows": rows})))
    return res, _cpu() - c0, time.perf_counter() - w0


def _cpu() -> float:
    """CPU seconds of this process and of its finished children (the lag fits' worker processes)."""
    import resource

    return sum(resource.getrusage(who).ru_utime + resource.getrusage(who).ru_stime
               for who in (resource.RUSAGE_SELF, resource.RUSAGE_CHILDREN))


def _without_motor6(log, cutoff):
    """The log with the reference motor-6 terms taken out of joints 5 and 6 (velocities and accelerations of the
    positions through the same zero-phase low-pass as identify-arm's). Motor 6 turns at ``32 (dq5 + dq6)``: through
    ``G^T`` its inertia, viscous and Coulomb friction act on both joints as ``Iam6 (ddq5 + ddq6) + fvm6 (dq5 + dq6)
    + fsm6 sgn(dq5 + dq6)``. The source's regressor gives joint 5 the columns ``ddq6, dq6, sgn(dq5 + dq6)`` and
    joint 6 ``ddq5, dq5, sgn(dq5 + dq6)``: each joint's own ``Ia`` and ``fv`` hold the rest, so its ``fv5`` and
    ``fv6`` include ``fvm6``; without the motor's terms the joints' viscous friction is ``fv - fvm6``."""
    import dataclasses

    from scipy.signal import butter, filtfilt

    Ts = float(np.median(np.diff(log.t)))
    b, a = butter(4, cutoff * 2 * Ts)
    dq = np.gradient(filtfilt(b, a, log.q, axis=0), Ts, axis=0)
    ddq = np.gradient(dq, Ts, axis=0)
    w = dq[:, 4] + dq[:, 5]
    m6 = REFERENCE["Iam6"] * (ddq[:, 4] + ddq[:, 5]) + REFERENCE["fvm6"] * w + REFERENCE["fsm6"] * np.sign(w)
    tau = log.tau.copy()
    tau[:, 4:6] -= m6[:, None]
    return dataclasses.replace(log, tau=tau)


def _motor_log():
    z = np.load(LOG)
    return (np.column_stack([z[f"q{j + 1}"] for j in range(6)]).astype(float),
            np.column_stack([z[f"tau{j + 1}"] for j in range(6)]).astype(float))


def _figaroh_rows(model, q, dq, ddq, tau):
    """Per joint the regressor block (n, 87) and torque (n,): 60 inertial, (Ia, fv, fs, off) x 6, Iam6 fvm6 fsm6."""
    import pinocchio as pin

    n = q.shape[0]
    data = model.createData()
    Y = np.empty((n, 6, 60))
    for k in range(n):
        Y[k] = pin.computeJointTorqueRegressor(model, data, q[k], dq[k], ddq[k])
    blocks = []
    s56 = np.sign(dq[:, 4] + dq[:, 5])
    for i in range(6):
        W = np.zeros((n, 87))
        W[:, :60] = Y[:, i, :]
        W[:, 60 + 4 * i: 64 + 4 * i] = np.column_stack([ddq[:, i], dq[:, i], np.sign(dq[:, i]), np.ones(n)])
        if i == 4:
            W[:, 84:] = np.column_stack([ddq[:, 5], dq[:, 5], s56])
        elif i == 5:
            W[:, 84:] = np.column_stack([ddq[:, 4], dq[:, 4], s56])
        blocks.append((W, tau[:, i]))
    return blocks


def figaroh_idim_ls():
    """FIGAROH's IDIM-LS of the TX40 log (module docstring: the steps): ``{"fv", "fs", "fv_std", "fs_std",
    "fvm6", "fsm6"}`` (std in % of the value), and the CPU seconds it took."""
    import pinocchio as pin
    from scipy import signal

    c0 = time.process_time()
    qm, taum = _motor_log()
    red_q = np.diag(RATIO)
    red_q[5, 4] = RATIO[5]
    red_tau = np.diag(RATIO)
    red_tau[4, 5] = RATIO[5]
    b, a = signal.butter(4, TS * CUTOFF / 2, "low")  # FIGAROH's low_pass_filter_data, as written there
    q = signal.filtfilt(b, a, qm @ np.linalg.inv(red_q).T, axis=0, padtype="odd",
                        padlen=3 * (max(len(a), len(b)) - 1))[20:-20]
    q[:, 1] -= np.pi / 2
    q[:, 2] += np.pi / 2
    dq = np.diff(q, axis=0) / TS  # calculate_first_second_order_differentiation
    ddq = np.gradient(dq, axis=0, edge_order=1) / TS
    q, dq, ddq = q[:-2], dq[:-1], ddq[:-1]
    tau = (taum @ red_tau.T)[20:-20][: q.shape[0]]  # the torques cut as the positions (_sync_torque_w_kinematics)
    model = pin.buildModelFromUrdf(str(URDF))
    Ws, ys = [], []
    for i, (W, y) in enumerate(_figaroh_rows(model, q, dq, ddq, tau)):
        for _ in range(2):
            W = signal.decimate(W, 10, axis=0, zero_phase=True)
            y = signal.decimate(y, 10, zero_phase=True)
        fast = np.abs(W[:, 61 + 4 * i]) >= DQ_LIM[i]  # the column of fv_i: the joint's velocity
        Ws.append(W[fast])
        ys.append(y[fast])
    W, y = np.vstack(Ws), np.concatenate(ys)
    cols = np.flatnonzero(np.sum(W**2, axis=0) >= 0.001)  # eliminate_non_dynaffect(W, params, 0.001)
    W = W[:, cols]
    norm = np.linalg.norm(W, axis=0)
    Ws_ = W / norm
    x = np.linalg.lstsq(Ws_, y, rcond=None)[0]
    e = y - Ws_ @ x
    cov = (e @ e) / (W.shape[0] - np.linalg.matrix_rank(Ws_)) * np.linalg.pinv(Ws_.T @ Ws_)
    x, sd = x / norm, np.sqrt(np.diag(cov)) / norm
    at = {int(c): k for k, c in enumerate(cols)}
    out = {"fv": [], "fs": [], "fv_std": [], "fs_std": []}
    for i in range(6):
        for key, c in (("fv", 61 + 4 * i), ("fs", 62 + 4 * i)):
            out[key].append(float(x[at[c]]))
            out[key + "_std"].append(float(100 * sd[at[c]] / abs(x[at[c]])))
    out["fvm6"], out["fsm6"] = float(x[at[85]]), float(x[at[86]])
    return out, time.process_time() - c0


def _iv(j, k):
    lo, hi = j.interval95[k]
    return f"{j.params[k]:.3g} [{lo:.3g}, {hi:.3g}]"


def table(res, fig) -> str:
    """The per-joint table (str)."""
    head = (f"{'joint':<8}{'sigma [95 %]':>24}{'fv ref':>8}{'fv LS (std %)':>16}"
            f"{'Fc [95 %]':>24}{'fs ref':>8}{'fs LS (std %)':>16}")
    lines = [head, "-" * len(head)]
    for i, j in enumerate(res.joints):
        fv = f"{fig['fv'][i]:.3g} ({fig['fv_std'][i]:.2g})" if fig else "-"
        fs = f"{fig['fs'][i]:.3g} ({fig['fs_std'][i]:.2g})" if fig else "-"
        lines.append(f"{j.name:<8}{_iv(j, 'sigma'):>24}{REFERENCE['fv'][i]:>8.3g}{fv:>16}"
                     f"{_iv(j, 'Fc'):>24}{REFERENCE['fs'][i]:>8.3g}{fs:>16}")
    lines.append(f"motor 6 on joints 5, 6 (sgn(dq5 + dq6)): fvm6 ref {REFERENCE['fvm6']:.3g}"
                 + (f", LS {fig['fvm6']:.3g}" if fig else "") + f"; fsm6 ref {REFERENCE['fsm6']:.3g}"
                 + (f", LS {fig['fsm6']:.3g}" if fig else "") + "; identify-arm: none (per-joint friction only)")
    return "\n".join(lines)


def _sensitivity(cutoffs, bootstrap: int, seed: int, rows: str) -> None:
    print(f"\nsigma / Fc per cutoff ({bootstrap} bootstrap refits; S: a Stribeck term kept, Fs then Stribeck's)")
    print(f"{'cutoff':>7}" + "".join(f"{f'joint_{i + 1}':>16}" for i in range(6)) + f"{'CPU [s]':>9}")
    for c in cutoffs:
        res, cpu, _ = identify(bootstrap, seed, cutoff=c, progress=False, lag=False, rows=rows)
        cells = [f"{j.params['sigma']:.3g} / {j.params['Fc']:.3g}{' S' if np.isfinite(j.params['Vs']) else ''}"
                 for j in res.joints]
        print(f"{c:>7g}" + "".join(f"{x:>16}" for x in cells) + f"{cpu:>9.1f}")
    print(f"{'ref':>7}" + "".join(f"{f'{v:.3g} / {c:.3g}':>16}" for v, c in zip(REFERENCE['fv'], REFERENCE['fs'])))


def _motor6(bootstrap: int, seed: int, rows: str) -> None:
    res, _, _ = identify(bootstrap, seed, motor6_removed=True, progress=False, lag=False, rows=rows)
    print(f"\nthe reference motor-6 terms subtracted from joints 5 and 6 first ({bootstrap} bootstrap refits):")
    for i in (4, 5):
        j = res.joints[i]
        fv = REFERENCE["fv"][i] - REFERENCE["fvm6"]
        print(f"{j.name}: sigma {_iv(j, 'sigma')} (ref fv{i + 1} - fvm6 = {fv:.3g}), Fc {_iv(j, 'Fc')} "
              f"(ref fs{i + 1} {REFERENCE['fs'][i]:.3g}), residual rms {res.info['rms'][i]:.3g} N·m")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--bootstrap", type=int, default=200)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-figaroh", action="store_true", help="skip the FIGAROH IDIM-LS replay")
    ap.add_argument("--quick", action="store_true", help="only the first table")
    ap.add_argument("--rows", choices=ROWS, default=DEFAULT_ROWS,
                    help=f"identify-arm's rows (default {DEFAULT_ROWS}, its default); the other's values follow")
    args = ap.parse_args(argv)
    res, cpu, wall = identify(args.bootstrap, args.seed, rows=args.rows)
    fig, fig_cpu = (None, 0.0) if args.no_figaroh else figaroh_idim_ls()
    print(f"identify-arm --cutoff {CUTOFF_ARM:g}" + ("" if args.rows == DEFAULT_ROWS else f" --rows {args.rows}")
          + "; units: sigma, fv in N·m·s/rad; Fc, fs in N·m (joint side)")
    print(table(res, fig))
    stribeck = [f"{j.name} Fs {j.params['Fs']:.3g} Vs {j.params['Vs']:.3g}" for j in res.joints
                if np.isfinite(j.params["Vs"])]
    print("Stribeck terms kept: " + ("; ".join(stribeck) if stribeck else "none"))
    print("offsets (N·m): " + ", ".join(f"{j.params['offset']:.3g} (ref {r:.3g})"
                                         for j, r in zip(res.joints, REFERENCE["offset"])))
    print(f"rows per joint {res.info['rows']}, residual rms (N·m) "
          + ", ".join(f"{v:.3g}" for v in res.info["rms"]) + f", cond {res.cond:.3g}")
    print("friction lag tau [95 %] (ms), velocity noise (mrad/s): " + "; ".join(
        f"{j.name} " + (f"{1e3 * j.params['tau']:.3g} [{1e3 * j.interval95['tau'][0]:.3g}, "
                        f"{1e3 * j.interval95['tau'][1]:.3g}]" if np.isfinite(j.params["tau"]) else "null")
        + f", {1e3 * j.noise_std:.3g}" for j in res.joints))
    print(f"identify-arm on 45000 samples x 6 joints: {cpu:.1f} s CPU, {wall:.1f} s wall "
          f"({args.bootstrap} bootstrap refits, the lag fits {sum(1 for j in res.joints if j.lag_info)} joints)"
          + ("" if fig is None else f"; FIGAROH replay {fig_cpu:.1f} s CPU"))
    _, cpu0, wall0 = identify(args.bootstrap, args.seed, progress=False, lag=False, rows=args.rows)
    print(f"the same with --no-lag: {cpu0:.1f} s CPU, {wall0:.1f} s wall")
    other = next(r for r in ROWS if r != args.rows)
    alt, _, _ = identify(args.bootstrap, args.seed, progress=False, lag=False, rows=other)
    how = {"sliding": "the rows near rest left out, friction columns through the torque's filter",
           "moving": "every row above the 2 % speed, each the filter of the moving samples alone"}[other]
    print(f"with --rows {other} ({how}), sigma / Fc: "
          + ", ".join(f"{j.params['sigma']:.3g} / {j.params['Fc']:.3g}" + (" S" if np.isfinite(j.params["Vs"]) else "")
                      for j in alt.joints)
          + f"; rows per joint {alt.info['rows']}")
    if not args.quick:
        _sensitivity((20.0, 40.0, 80.0, 150.0), 20, args.seed, args.rows)
        _motor6(50, args.seed, args.rows)


if __name__ == "__main__":
    main()
