/* aff_error.h -- the error codes of the components' configuration (aff_*_init), one enum for the library.
 *
 * Every component of the drive's code is configured from a config struct (aff_X_config, its defaults from
 * aff_X_default_config) by aff_X_init, which checks every field before it writes anything and returns AFF_OK or
 * the code of the first field out of its range, named by component and field (AFF_ERR_SUPERVISOR_WINDOW: the
 * supervisor's window). aff_error_message gives a sentence naming the field, its unit and its valid range. The
 * codes are grouped by component in blocks of 20 (a code keeps its number when a component gains a field).
 * The same settings in the Python classes raise plant.errors.ParameterError with that sentence.
 */
#ifndef AFF_ERROR_H
#define AFF_ERROR_H

typedef enum aff_error {
    AFF_OK = 0,                          /* configured */
    AFF_ERR_NULL = 1,                    /* a NULL pointer */
    /* the input guard (aff_drive.h) */
    AFF_ERR_GUARD_TC = 2,
    AFF_ERR_GUARD_W_MAX = 3,
    AFF_ERR_GUARD_U_MAX = 4,
    AFF_ERR_GUARD_HOLD_TIME = 5,
    /* the drive (aff_drive.h) */
    AFF_ERR_DRIVE_TC = 10,               /* the parts' controller periods differ */
    /* the outlier gate (aff_gate.h) */
    AFF_ERR_GATE_MAX_STEP = 20,
    AFF_ERR_GATE_N_SIGMA = 21,
    AFF_ERR_GATE_ALPHA = 22,
    AFF_ERR_GATE_MAX_CONSECUTIVE = 23,
    /* the range gate (aff_gate.h) */
    AFF_ERR_RANGE_GATE_X_MAX = 40,
    AFF_ERR_RANGE_GATE_FACTOR = 41,
    AFF_ERR_RANGE_GATE_FLOOR = 42,
    AFF_ERR_RANGE_GATE_MEMORY = 43,
    AFF_ERR_RANGE_GATE_MAX_CONSECUTIVE = 44,
    /* recursive least squares (aff_rls.h) */
    AFF_ERR_RLS_N_PARAMS = 60,
    AFF_ERR_RLS_FORGETTING = 61,
    AFF_ERR_RLS_LAM = 62,
    AFF_ERR_RLS_P0 = 63,
    AFF_ERR_RLS_P_MAX = 64,
    AFF_ERR_RLS_LAM_EACH = 65,
    AFF_ERR_RLS_P = 66,
    /* the loop model (aff_velocity_input.h) */
    AFF_ERR_LOOP_MODEL_TC = 80,
    AFF_ERR_LOOP_MODEL_KP = 81,
    AFF_ERR_LOOP_MODEL_KI = 82,
    AFF_ERR_LOOP_MODEL_GAINS = 83,
    AFF_ERR_LOOP_MODEL_J = 84,
    AFF_ERR_LOOP_MODEL_TRACK = 85,
    /* the sign observer (aff_velocity_input.h) */
    AFF_ERR_SIGN_OBSERVER_TC = 100,
    AFF_ERR_SIGN_OBSERVER_J = 101,
    AFF_ERR_SIGN_OBSERVER_BANDWIDTH = 102,
    AFF_ERR_SIGN_OBSERVER_RESIDUAL_BANDWIDTH = 103,
    /* the fixed feedforward (aff_feedforward.h) */
    AFF_ERR_FIXED_FF_DT = 120,
    AFF_ERR_FIXED_FF_LAG = 121,
    AFF_ERR_FIXED_FF_FF_MAX = 122,
    AFF_ERR_FIXED_FF_SIGN_WIDTH = 123,
    AFF_ERR_FIXED_FF_STICK_BAND = 124,
    AFF_ERR_FIXED_FF_STICK_SAMPLES = 125,
    AFF_ERR_FIXED_FF_AT_REF = 126,
    AFF_ERR_FIXED_FF_W_MAX = 127,
    AFF_ERR_FIXED_FF_USE_LOOP_MODEL = 128,
    AFF_ERR_FIXED_FF_USE_SIGN_OBSERVER = 129,
    /* the sliding-regime estimator (aff_sliding.h) */
    AFF_ERR_SLIDING_VS = 140,
    AFF_ERR_SLIDING_DELTA = 141,
    AFF_ERR_SLIDING_TC = 142,
    AFF_ERR_SLIDING_TS = 143,
    AFF_ERR_SLIDING_T_FILTER = 144,
    AFF_ERR_SLIDING_FORGETTING = 145,
    AFF_ERR_SLIDING_LAM = 146,
    AFF_ERR_SLIDING_LAM_EACH = 147,
    AFF_ERR_SLIDING_P0 = 148,
    AFF_ERR_SLIDING_P_MAX = 149,
    AFF_ERR_SLIDING_LAG = 150,
    AFF_ERR_SLIDING_OFFSET = 151,
    AFF_ERR_SLIDING_W_BAND_MIN = 152,
    AFF_ERR_SLIDING_DWELL_MAX = 153,
    AFF_ERR_SLIDING_J_MAX = 154,
    AFF_ERR_SLIDING_TAU_MAX = 155,
    AFF_ERR_SLIDING_INITIAL = 156,
    /* the provisional start map (aff_robust_ff.h) */
    AFF_ERR_START_ON = 160,
    AFF_ERR_START_FC = 161,
    AFF_ERR_START_FS = 162,
    AFF_ERR_START_SIGMA = 163,
    AFF_ERR_START_TAU = 164,
    AFF_ERR_START_VS = 165,
    AFF_ERR_START_DELTA = 166,
    AFF_ERR_START_GAIN = 167,
    AFF_ERR_START_AT_REF = 168,
    /* the robust adaptive feedforward (aff_robust_ff.h) */
    AFF_ERR_ROBUST_FF_WARMUP = 180,
    AFF_ERR_ROBUST_FF_FADE_IN = 181,
    AFF_ERR_ROBUST_FF_J_RANGE = 182,
    AFF_ERR_ROBUST_FF_TAU_MAX = 183,
    AFF_ERR_ROBUST_FF_CONSISTENCY = 184,
    AFF_ERR_ROBUST_FF_LAG_MARGIN = 185,
    AFF_ERR_ROBUST_FF_LAG_MARGIN_MAX = 186,
    AFF_ERR_ROBUST_FF_MAX_REL_STDERR = 187,
    AFF_ERR_ROBUST_FF_LAG_MEMORY = 188,
    AFF_ERR_ROBUST_FF_LAG_ZERO = 189,
    AFF_ERR_ROBUST_FF_PROJECT = 190,
    /* the feedforward supervisor (aff_supervisor.h) */
    AFF_ERR_SUPERVISOR_TC = 200,
    AFF_ERR_SUPERVISOR_J_N = 201,
    AFF_ERR_SUPERVISOR_OMEGA = 202,
    AFF_ERR_SUPERVISOR_WINDOW = 203,
    AFF_ERR_SUPERVISOR_MARGIN = 204,
    AFF_ERR_SUPERVISOR_SETTLE = 205,
    AFF_ERR_SUPERVISOR_REST_BAND = 206,
    AFF_ERR_SUPERVISOR_DELAY = 207,
    AFF_ERR_SUPERVISOR_KP = 208,
    AFF_ERR_SUPERVISOR_KI = 209,
    AFF_ERR_SUPERVISOR_TRACK_MARGIN = 210,
    /* the disturbance observer (aff_dob.h) */
    AFF_ERR_DOB_TC = 220,
    AFF_ERR_DOB_J_N = 221,
    AFF_ERR_DOB_OMEGA_Q = 222,
    AFF_ERR_DOB_ORDER = 223,
    AFF_ERR_DOB_D_MAX = 224,
    /* the eq. 4 feedforward (aff_eq4_ff.h) */
    AFF_ERR_EQ4_FF_TS = 300,
    AFF_ERR_EQ4_FF_LAM = 301,
    AFF_ERR_EQ4_FF_P0 = 302,
    AFF_ERR_EQ4_FF_WARMUP = 303,
    AFF_ERR_EQ4_FF_TAU_MAX = 304,
    AFF_ERR_EQ4_FF_IV = 305,
    AFF_ERR_EQ4_FF_W_BAND = 306,
    AFF_ERR_EQ4_FF_MAP_REL_STDERR = 307,
    /* the Canudas de Wit et al. compensator (controllers/csrc/ctl_canudas.h) */
    AFF_ERR_CANUDAS_TC = 320,
    AFF_ERR_CANUDAS_TS = 321,
    AFF_ERR_CANUDAS_FORGETTING = 322,
    AFF_ERR_CANUDAS_LAM = 323,
    AFF_ERR_CANUDAS_P0 = 324,
    AFF_ERR_CANUDAS_J_GUESS = 325,
    AFF_ERR_CANUDAS_W_DEAD = 326,
    AFF_ERR_CANUDAS_WARMUP = 327,
    AFF_ERR_CANUDAS_FF_MAX = 328,
    AFF_ERR_CANUDAS_FF_MEASURED = 329,
    /* the residual switch-in (aff_residual.h) */
    AFF_ERR_SWITCH_IN_TC = 240,
    AFF_ERR_SWITCH_IN_J_N = 241,
    AFF_ERR_SWITCH_IN_KP = 242,
    AFF_ERR_SWITCH_IN_KI = 243,
    AFF_ERR_SWITCH_IN_WINDOW = 244,
    AFF_ERR_SWITCH_IN_RATIO = 245,
    AFF_ERR_SWITCH_IN_SHARE = 246,
    AFF_ERR_SWITCH_IN_FADE_IN = 247,
    AFF_ERR_SWITCH_IN_TRIAL_MARGIN = 248,
    /* the residual observer (aff_residual.h) */
    AFF_ERR_RESIDUAL_U_MAX = 260,
    AFF_ERR_RESIDUAL_USE_SWITCH_IN = 261,
    AFF_ERR_RESIDUAL_CROSSOVER = 262,
    AFF_ERR_RESIDUAL_SLEW_TIME = 263,
    /* mode "adaptive" (aff_adaptive.h) */
    AFF_ERR_ADAPTIVE_USE_RESIDUAL = 280,
    AFF_ERR_ADAPTIVE_USE_SUPERVISOR = 281
} aff_error;

/* A sentence for the code e: the field, its unit and its valid range (never NULL; "unknown error code" for a
 * number that is no aff_error). */
const char *aff_error_message(aff_error e);

#endif
