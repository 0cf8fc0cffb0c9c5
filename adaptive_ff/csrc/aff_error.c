/* aff_error.c -- the sentences of the error codes (see aff_error.h). */
#include "aff_error.h"

const char *aff_error_message(aff_error e)
{
    switch (e) {
    case AFF_OK:
        return "configured";
    case AFF_ERR_NULL:
        return "a NULL pointer was given for the struct to configure or for its configuration";
    case AFF_ERR_GUARD_TC:
        return "guard: Tc (controller period, s) must be finite and > 0";
    case AFF_ERR_GUARD_W_MAX:
        return "guard: w_max (largest plausible velocity, rad/s) must be finite and > 0";
    case AFF_ERR_GUARD_U_MAX:
        return "guard: u_max (largest plausible torque, N*m) must be finite and > 0";
    case AFF_ERR_GUARD_HOLD_TIME:
        return "guard: hold_time (s) must be finite and at least Tc";
    case AFF_ERR_DRIVE_TC:
        return "drive: the controller periods (s) of guard.Tc, mode.ff.ff.dt, mode.ff.est.Tc and of the acting parts "
               "mode.res.dob.Tc, mode.res.switch_in.Tc, mode.sup.Tc must be one and the same";
    case AFF_ERR_GATE_MAX_STEP:
        return "outlier gate: max_step (largest plausible change per sample, signal unit) must be finite and >= 0, "
               "or INFINITY (none)";
    case AFF_ERR_GATE_N_SIGMA:
        return "outlier gate: n_sigma (noise allowance in running-scale units, -) must be finite and > 0";
    case AFF_ERR_GATE_ALPHA:
        return "outlier gate: alpha (smoothing factor of the running scale, -) must be in (0, 1]";
    case AFF_ERR_GATE_MAX_CONSECUTIVE:
        return "outlier gate: max_consecutive (rejections before a sample is accepted again) must be >= 1";
    case AFF_ERR_RANGE_GATE_X_MAX:
        return "range gate: x_max (absolute bound, signal unit) must be > 0 (INFINITY: none)";
    case AFF_ERR_RANGE_GATE_FACTOR:
        return "range gate: factor (relative bound, -) must be finite and > 1";
    case AFF_ERR_RANGE_GATE_FLOOR:
        return "range gate: floor (smallest reference scale, signal unit) must be finite and >= 0";
    case AFF_ERR_RANGE_GATE_MEMORY:
        return "range gate: memory (decay time of the envelope, samples) must be finite and > 0";
    case AFF_ERR_RANGE_GATE_MAX_CONSECUTIVE:
        return "range gate: max_consecutive (rejections before a sample is accepted again) must be >= 1";
    case AFF_ERR_RLS_N_PARAMS:
        return "RLS: n_params (number of parameters) must be in 1..AFF_RLS_NMAX (16)";
    case AFF_ERR_RLS_FORGETTING:
        return "RLS: forgetting must be AFF_RLS_EXPONENTIAL, AFF_RLS_DIRECTIONAL or AFF_RLS_VECTOR (the "
               "per-parameter factors need AFF_RLS_VECTOR)";
    case AFF_ERR_RLS_LAM:
        return "RLS: lam (forgetting factor, -) must be in (0, 1]";
    case AFF_ERR_RLS_P0:
        return "RLS: P0 (initial covariance scale) must be finite and > 0";
    case AFF_ERR_RLS_P_MAX:
        return "RLS: P_max (bound on trace(P)) must be > 0 (INFINITY: none; 0: trace(P0*I))";
    case AFF_ERR_RLS_P:
        return "RLS: P (covariance) must be finite, symmetric and positive definite";
    case AFF_ERR_RLS_LAM_EACH:
        return "RLS: each per-parameter forgetting factor (-) must be in (0, 1]";
    case AFF_ERR_LOOP_MODEL_TC:
        return "loop model: the feedforward's period (s) must be finite and > 0";
    case AFF_ERR_LOOP_MODEL_KP:
        return "loop model: Kp (proportional gain of the loop's PI, N*m*s/rad) must be finite and >= 0";
    case AFF_ERR_LOOP_MODEL_KI:
        return "loop model: Ki (integral gain of the loop's PI, N*m/rad) must be finite and >= 0";
    case AFF_ERR_LOOP_MODEL_GAINS:
        return "loop model: Kp and Ki are both 0 (no loop): set the loop's PI gains";
    case AFF_ERR_LOOP_MODEL_J:
        return "loop model: J (design inertia, kg*m^2) must be finite and > 0";
    case AFF_ERR_LOOP_MODEL_TRACK:
        return "loop model: track (tracking bandwidth, rad/s) must be finite: >= 0, or < 0 for Kp/J";
    case AFF_ERR_SIGN_OBSERVER_TC:
        return "sign observer: the feedforward's period (s) must be finite and > 0";
    case AFF_ERR_SIGN_OBSERVER_J:
        return "sign observer: J (design inertia, kg*m^2) must be finite and > 0";
    case AFF_ERR_SIGN_OBSERVER_BANDWIDTH:
        return "sign observer: bandwidth (rad/s) must be finite and > 0";
    case AFF_ERR_SIGN_OBSERVER_RESIDUAL_BANDWIDTH:
        return "sign observer: residual_bandwidth (rad/s) must be finite: >= 0, or < 0 for 0.1*bandwidth";
    case AFF_ERR_FIXED_FF_DT:
        return "feedforward: dt (call period, s) must be finite and > 0";
    case AFF_ERR_FIXED_FF_LAG:
        return "feedforward: lag must be 0 or 1";
    case AFF_ERR_FIXED_FF_FF_MAX:
        return "feedforward: ff_max (bound on the feedforward, N*m) must be >= 0 (INFINITY: none)";
    case AFF_ERR_FIXED_FF_SIGN_WIDTH:
        return "feedforward: sign_width (half-width of the sign ramp, rad/s) must be finite and >= 0";
    case AFF_ERR_FIXED_FF_STICK_BAND:
        return "feedforward: stick_band (stick-detection band, rad/s) must be finite and >= 0";
    case AFF_ERR_FIXED_FF_STICK_SAMPLES:
        return "feedforward: stick_samples (in-band samples that declare sticking) must be >= 1";
    case AFF_ERR_FIXED_FF_AT_REF:
        return "feedforward: at_ref must be 0 (at the measurement) or 1 (at the reference)";
    case AFF_ERR_FIXED_FF_W_MAX:
        return "feedforward: w_max (largest plausible speed, rad/s) must be > 0 (INFINITY: none)";
    case AFF_ERR_FIXED_FF_USE_LOOP_MODEL:
        return "feedforward: use_loop_model must be 0 or 1";
    case AFF_ERR_FIXED_FF_USE_SIGN_OBSERVER:
        return "feedforward: use_sign_observer must be 0 or 1";
    case AFF_ERR_SLIDING_VS:
        return "estimator: Vs (Stribeck velocity, rad/s) must be finite and > 0: set the identification's";
    case AFF_ERR_SLIDING_DELTA:
        return "estimator: delta (Stribeck shape factor, 1) must be finite and non-zero: set the identification's";
    case AFF_ERR_SLIDING_TC:
        return "estimator: Tc (controller period, s) must be finite and > 0";
    case AFF_ERR_SLIDING_TS:
        return "estimator: Ts (RLS update period, s) must be a positive multiple of Tc (at most 1e9 times it)";
    case AFF_ERR_SLIDING_T_FILTER:
        return "estimator: T_filter (filter time constant, s) must be finite and at least 2*Tc";
    case AFF_ERR_SLIDING_FORGETTING:
        return "estimator: forgetting must be AFF_RLS_EXPONENTIAL, AFF_RLS_DIRECTIONAL or AFF_RLS_VECTOR";
    case AFF_ERR_SLIDING_LAM:
        return "estimator: lam (forgetting factor per RLS update, -) must be in (0, 1]";
    case AFF_ERR_SLIDING_LAM_EACH:
        return "estimator: lam_each (per-parameter forgetting factors of AFF_RLS_VECTOR, -) must be in (0, 1] for "
               "each parameter";
    case AFF_ERR_SLIDING_P0:
        return "estimator: P0 (initial covariance scale) must be finite and > 0";
    case AFF_ERR_SLIDING_P_MAX:
        return "estimator: P_max (bound on trace(P)) must be > 0 (INFINITY: none; 0: p*P0)";
    case AFF_ERR_SLIDING_LAG:
        return "estimator: lag must be 0 or 1";
    case AFF_ERR_SLIDING_OFFSET:
        return "estimator: offset must be 0 or 1";
    case AFF_ERR_SLIDING_W_BAND_MIN:
        return "estimator: w_band_min (smallest near-zero band, rad/s) must be finite and >= 0 (0: 0.1*Vs)";
    case AFF_ERR_SLIDING_DWELL_MAX:
        return "estimator: dwell_max (largest filtered near-zero indicator, -) must be in [0, 1]";
    case AFF_ERR_SLIDING_J_MAX:
        return "estimator: J_max (upper bound of J, kg*m^2) must be > 0 (INFINITY: none)";
    case AFF_ERR_SLIDING_TAU_MAX:
        return "estimator: tau_max (upper bound of tau, s) must be finite and > 0";
    case AFF_ERR_SLIDING_INITIAL:
        return "estimator: the start initial_J (kg*m^2), initial_tau (s), initial_Fc, initial_Fs, initial_offset "
               "(N*m), initial_sigma (N*m*s/rad) must be finite";
    case AFF_ERR_START_ON:
        return "start map: on must be 0 or 1";
    case AFF_ERR_START_FC:
        return "start map: Fc (Coulomb level, N*m) must be finite and >= 0";
    case AFF_ERR_START_FS:
        return "start map: Fs (static level, N*m) must be finite and >= 0";
    case AFF_ERR_START_SIGMA:
        return "start map: sigma (viscous coefficient, N*m*s/rad) must be finite and >= 0";
    case AFF_ERR_START_TAU:
        return "start map: tau (lag, s) must be finite and >= 0";
    case AFF_ERR_START_VS:
        return "start map: Vs (Stribeck velocity, rad/s) must be finite and > 0 (0: the estimator's)";
    case AFF_ERR_START_DELTA:
        return "start map: delta (Stribeck shape factor, 1) must be finite (0: the estimator's)";
    case AFF_ERR_START_GAIN:
        return "start map: gain (factor on the start map, -) must be in (0, 1]";
    case AFF_ERR_START_AT_REF:
        return "start map: at_ref must be 0 or 1";
    case AFF_ERR_ROBUST_FF_WARMUP:
        return "adaptive feedforward: warmup (RLS updates before switch-on) must be >= 0";
    case AFF_ERR_ROBUST_FF_FADE_IN:
        return "adaptive feedforward: fade_in (s) must be finite and >= 0";
    case AFF_ERR_ROBUST_FF_J_RANGE:
        return "adaptive feedforward: J_lo, J_hi (plausible inertia interval, kg*m^2) must satisfy 0 <= J_lo < J_hi, "
               "J_lo finite";
    case AFF_ERR_ROBUST_FF_TAU_MAX:
        return "adaptive feedforward: tau_max (largest plausible lag, s) must be finite and > 0";
    case AFF_ERR_ROBUST_FF_CONSISTENCY:
        return "adaptive feedforward: consistency (relative lag tolerance, -) must be finite and > 0";
    case AFF_ERR_ROBUST_FF_LAG_MARGIN:
        return "adaptive feedforward: lag_margin (standard errors, -) must be finite and >= 0";
    case AFF_ERR_ROBUST_FF_LAG_MARGIN_MAX:
        return "adaptive feedforward: lag_margin_max (fraction of the lag, -) must be >= 0 (INFINITY: no cap)";
    case AFF_ERR_ROBUST_FF_MAX_REL_STDERR:
        return "adaptive feedforward: max_rel_stderr (-) must be > 0 (INFINITY: no test)";
    case AFF_ERR_ROBUST_FF_LAG_MEMORY:
        return "adaptive feedforward: lag_memory (s) must be finite and >= 0";
    case AFF_ERR_ROBUST_FF_LAG_ZERO:
        return "adaptive feedforward: lag_zero (standard errors, -) must be >= 0 (INFINITY: every negative lag)";
    case AFF_ERR_ROBUST_FF_PROJECT:
        return "adaptive feedforward: project must be 0 or 1";
    case AFF_ERR_SUPERVISOR_TC:
        return "supervisor: Tc (controller period, s) must be finite and > 0";
    case AFF_ERR_SUPERVISOR_J_N:
        return "supervisor: J_n (design inertia, kg*m^2) must be finite and > 0: set it";
    case AFF_ERR_SUPERVISOR_OMEGA:
        return "supervisor: omega (Q-filter cut-off, rad/s) must be finite and > 0: set it (e.g. Kp/J_n)";
    case AFF_ERR_SUPERVISOR_WINDOW:
        return "supervisor: window (EWMA time constant, s) must be finite and > 0";
    case AFF_ERR_SUPERVISOR_MARGIN:
        return "supervisor: margin (hysteresis, -) must be in [0, 1)";
    case AFF_ERR_SUPERVISOR_SETTLE:
        return "supervisor: settle (s) must be finite: >= 0, or < 0 for window/2";
    case AFF_ERR_SUPERVISOR_REST_BAND:
        return "supervisor: rest_band (rad/s) must be finite and >= 0, or -1 (no rest rule)";
    case AFF_ERR_SUPERVISOR_DELAY:
        return "supervisor: delay (measurement delay, periods) must be in 0..AFF_SUPERVISOR_DELAY_MAX (32)";
    case AFF_ERR_SUPERVISOR_KP:
        return "supervisor: Kp (the loop's proportional gain, N*m*s/rad) must be finite and >= 0 (0: no tracking test)";
    case AFF_ERR_SUPERVISOR_KI:
        return "supervisor: Ki (the loop's integral gain, N*m/rad) must be finite and >= 0";
    case AFF_ERR_SUPERVISOR_TRACK_MARGIN:
        return "supervisor: track_margin (-) must be finite and >= 0";
    case AFF_ERR_DOB_TC:
        return "observer: Tc (controller period, s) must be finite and > 0";
    case AFF_ERR_DOB_J_N:
        return "observer: J_n (nominal inertia, kg*m^2) must be finite and > 0: set it";
    case AFF_ERR_DOB_OMEGA_Q:
        return "observer: omega_q (Q-filter cut-off, rad/s) must be finite and > 0";
    case AFF_ERR_DOB_ORDER:
        return "observer: order (of the binomial Q-filter) must be in 1..AFF_DOB_ORDER_MAX (8)";
    case AFF_ERR_DOB_D_MAX:
        return "observer: d_max (bound on the estimate, N*m) must be >= 0 (INFINITY: none)";
    case AFF_ERR_EQ4_FF_TS:
        return "eq. 4 feedforward: Ts (sample time of the stream, s) must be finite and > 0";
    case AFF_ERR_EQ4_FF_LAM:
        return "eq. 4 feedforward: lam (forgetting factor, -) must be in (0, 1]";
    case AFF_ERR_EQ4_FF_P0:
        return "eq. 4 feedforward: P0 (initial covariance scale) must be finite and > 0";
    case AFF_ERR_EQ4_FF_WARMUP:
        return "eq. 4 feedforward: warmup (accepted samples before switch-on) must be >= 0";
    case AFF_ERR_EQ4_FF_TAU_MAX:
        return "eq. 4 feedforward: tau_max (upper projection bound of tau, s) must be finite and > 0";
    case AFF_ERR_EQ4_FF_IV:
        return "eq. 4 feedforward: iv must be 0 or 1";
    case AFF_ERR_EQ4_FF_W_BAND:
        return "eq. 4 feedforward: w_band (sliding-regime gate, rad/s) must be finite and >= 0";
    case AFF_ERR_EQ4_FF_MAP_REL_STDERR:
        return "eq. 4 feedforward: map_rel_stderr (determinacy bound, -) must be > 0 (INFINITY: none), and a finite "
               "one needs iv (the test is on the IV estimate's covariance)";
    case AFF_ERR_CANUDAS_TC:
        return "Canudas compensator: Tc (controller period, s) must be finite and > 0";
    case AFF_ERR_CANUDAS_TS:
        return "Canudas compensator: Ts (estimator period, s) must be finite and > 0";
    case AFF_ERR_CANUDAS_FORGETTING:
        return "Canudas compensator: forgetting must be AFF_RLS_EXPONENTIAL or AFF_RLS_DIRECTIONAL";
    case AFF_ERR_CANUDAS_LAM:
        return "Canudas compensator: lam (forgetting factor, -) must be in (0, 1]";
    case AFF_ERR_CANUDAS_P0:
        return "Canudas compensator: P0 (initial covariance scale) must be finite and > 0";
    case AFF_ERR_CANUDAS_J_GUESS:
        return "Canudas compensator: J_guess (initial inertia, kg*m^2) must be finite and > 0";
    case AFF_ERR_CANUDAS_W_DEAD:
        return "Canudas compensator: w_dead (estimation dead zone, rad/s) must be finite and >= 0";
    case AFF_ERR_CANUDAS_WARMUP:
        return "Canudas compensator: warmup (RLS updates before switch-on) must be >= 0";
    case AFF_ERR_CANUDAS_FF_MAX:
        return "Canudas compensator: ff_max (bound on the compensation, N*m) must be >= 0 (INFINITY: none)";
    case AFF_ERR_CANUDAS_FF_MEASURED:
        return "Canudas compensator: ff_measured must be 0 or 1";
    case AFF_ERR_SWITCH_IN_TC:
        return "switch-in: Tc (controller period, s) must be finite and > 0";
    case AFF_ERR_SWITCH_IN_J_N:
        return "switch-in: J_n (design inertia, kg*m^2) must be finite and > 0: set it";
    case AFF_ERR_SWITCH_IN_KP:
        return "switch-in: Kp (the loop's proportional gain, N*m*s/rad) must be finite and > 0: set it";
    case AFF_ERR_SWITCH_IN_KI:
        return "switch-in: Ki (the loop's integral gain, N*m/rad) must be finite and >= 0";
    case AFF_ERR_SWITCH_IN_WINDOW:
        return "switch-in: window (s) must be finite and > 0";
    case AFF_ERR_SWITCH_IN_RATIO:
        return "switch-in: ratio (-) must be finite and > 0";
    case AFF_ERR_SWITCH_IN_SHARE:
        return "switch-in: share (-) must be finite and > 0";
    case AFF_ERR_SWITCH_IN_FADE_IN:
        return "switch-in: fade_in (s) must be finite and >= 0";
    case AFF_ERR_SWITCH_IN_TRIAL_MARGIN:
        return "switch-in: trial_margin (-) must be >= 0 (INFINITY: no trial)";
    case AFF_ERR_RESIDUAL_U_MAX:
        return "residual observer: u_max (bound on the output, N*m) must be >= 0 (INFINITY: none)";
    case AFF_ERR_RESIDUAL_USE_SWITCH_IN:
        return "residual observer: use_switch_in must be 0 or 1";
    case AFF_ERR_RESIDUAL_CROSSOVER:
        return "residual observer: crossover (the loop's Kp/J_n, rad/s) must be finite and >= 0 (0: no slew limit)";
    case AFF_ERR_RESIDUAL_SLEW_TIME:
        return "residual observer: slew_time (s) must be finite and >= 0 (0: no slew limit)";
    case AFF_ERR_ADAPTIVE_USE_RESIDUAL:
        return "mode adaptive: use_residual must be 0 or 1";
    case AFF_ERR_ADAPTIVE_USE_SUPERVISOR:
        return "mode adaptive: use_supervisor must be 0 or 1";
    }
    return "unknown error code";
}
