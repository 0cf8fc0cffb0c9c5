/* plant_params.h -- the plant's parameters and state: one struct each for every friction model of the package.
 *
 * Models (Ruderman, eqs. 1-3, and the variants of plant/asymmetric.py, plant/karnopp.py, plant/lugre.py):
 *
 *   lagged (lagged Stribeck, asymmetric, Karnopp):
 *     J*dw/dt = u - f,   tau*df/dt + f = F(w)   (f = F(w) algebraically if tau == 0)
 *     F: eq. 3 with the levels of the direction of w (p->pos for w > 0, p->neg for w < 0; asymmetric levels:
 *     Canudas de Wit, Astrom, Braun 1987); Karnopp (1985): Fs_stick*sgn inside the stick band |w| < dv.
 *   LuGre (Canudas de Wit, Olsson, Astrom, Lischinsky 1995, eqs. 2-5):
 *     dz/dt = w - sigma0*|w|/g(w)*z,   g(w) = eq. 3 at |w| with sigma = 0
 *     J*dw/dt = u - sigma0*z - sigma1*dz/dt - sigma2*w
 *
 * Friction ripple (position-dependent friction of harmonic drives and gearboxes, plant.ripple.FrictionRipple):
 * with ripple_a != 0 the friction map is multiplied by R(q) = 1 + ripple_a*sin(ripple_n*q + ripple_phase), q the
 * joint position (rad, dq/dt = w, a state integrated by the same steps): the lagged models' target F(w) (the
 * Karnopp stick limit Fs_stick included) becomes F(w)*R(q); LuGre's g(w) and its viscous sigma2*w are scaled by
 * R(q) (the steady sliding friction (g(w)*sgn(w) + sigma2*w)*R(q), as the lagged models'), the bristle's
 * stiffness sigma0 and damping sigma1 (the contact's elasticity) are not. ripple_a == 0: every result bit for
 * bit that of the plant without ripple (every ripple operation sits behind a ripple_a != 0 branch).
 *
 * The Python packers (plant.rows.plant_params, lagged_params, plant_rows) fill plant_params from a validated
 * model; plant.rows.plant_state / plant_states (C: plant_steady_state) make a plant_state. The steps are in
 * plant_dynamics.h (RK4, plant_step) and plant_stiff.h (the implicit steps of stiff plants). Simulation code:
 * double only (no aff_real); the eq. 3 parts are plant_stribeck structs (double in the package build).
 */
#ifndef PLANT_PARAMS_H
#define PLANT_PARAMS_H
#include "plant_stribeck.h"

/* Friction model of a plant_params (the "model" key of a plant file, plant/models.py). */
typedef enum plant_model {
    PLANT_LAGGED_STRIBECK = 0, /* plant.friction.JointParams */
    PLANT_ASYMMETRIC = 1,      /* plant.asymmetric.AsymmetricParams */
    PLANT_KARNOPP = 2,         /* plant.karnopp.KarnoppParams */
    PLANT_LUGRE = 3            /* plant.lugre.LuGreParams */
} plant_model;

/* Parameters of one plant (unused fields 0). Units SI, joint side. */
typedef struct plant_params {
    plant_model model;
    double J;          /* inertia (kg*m^2) */
    double tau;        /* friction lag (s); 0: static map (lagged models), always 0 for LuGre */
    plant_stribeck pos; /* eq. 3 for w > 0: Fc, Fs - Fc (N*m), Vs (rad/s), delta, sigma (N*m*s/rad), cut-off
                           speed (rad/s, plant.stribeck_map.stribeck_cutoff). LuGre: its Fc, Fs - Fc, Vs, delta,
                           sigma2 and cut-off (g(w) is this map at |w| with sigma = 0) */
    plant_stribeck neg; /* the same for w < 0 (equal to pos but for the asymmetric model) */
    double Fs_stick;   /* Karnopp: friction limit in the stick band (Fs, N*m); else 0 */
    double dv;         /* Karnopp: half-width of the stick band (rad/s); 0 = no band */
    double sigma0;     /* LuGre bristle stiffness (N*m/rad) */
    double sigma1;     /* LuGre bristle damping (N*m*s/rad) */
    double g_min;      /* LuGre min(Fc, Fs) (N*m) */
    double g_max;      /* LuGre max(Fc, Fs) (N*m) */
    double base_rate;  /* LuGre (sigma1 + sigma2)/J + sqrt(sigma0/J) (1/s): bounds |l| of the pre-sliding
                          oscillator J*l^2 + (sigma1 + sigma2)*l + sigma0 = 0, damping included */
    double rate;       /* lagged models: fastest stable mode (1/s, plant.rows.lagged_rate): where rate*dt >
                          plant_rk4_rate_max the RK4 step is cut into (long)(rate*dt) + 1 sub-steps, beyond
                          PLANT_LAGGED_RK4_MAX the stiff step */
    double inv_J;      /* 1/J (1/(kg*m^2)), inf for J == 0 */
    double inv_tau;    /* 1/tau (1/s), 0 for tau == 0 */
    double ripple_a;   /* friction ripple amplitude a (dimensionless, 0 <= a < 1); 0: no ripple */
    double ripple_n;   /* ripple periods per joint revolution n (> 0 where a != 0) */
    double ripple_phase; /* ripple phase (rad) */
    double key;        /* fingerprint of the fields above (an integer in [1, 2^52)): see plant_state.aux */
} plant_params;

/* State of one plant. */
typedef struct plant_state {
    double w;    /* velocity (rad/s) */
    double s;    /* the model's internal state: friction torque f (N*m) of the lagged models, LuGre bristle
                    deflection z (rad) */
    double aux;  /* == p->key: s is F(w) (times R(q) with a ripple) of these parameters with tau == 0 (eq. 3
                    cache: the next step reuses it; a swapped parameter struct invalidates it by the key);
                    after a stiff step (plant_lagged_stiff_step, plant_lugre_stiff_step) its last sub-step (s);
                    any other value (NaN) means neither */
    double q;    /* joint position (rad), dq/dt = w; read only by the friction ripple (ripple_a != 0) */
} plant_state;

/* The friction map the RK4 stages evaluate at velocity w (rad/s), N*m. Lagged models: Fs_stick*sgn inside the
 * Karnopp band |w| < dv, else eq. 3 with the levels of the direction of w (NaN for NaN w). LuGre: the Stribeck
 * level g(w) = Fc + (Fs - Fc)*exp(-|w/Vs|^delta), its limit at w == 0. sgn: Karnopp breakaway direction (sgn(u))
 * when the step started in the stick band, else 0. Source: eq. 3 (plant_stribeck_eval); Karnopp (1985);
 * Canudas de Wit et al. (1995). Python: plant.rows.plant_target. */
double plant_target(const plant_params *p, double w, double sgn);

/* The ripple factor R(q) = 1 + ripple_a*sin(ripple_n*q + ripple_phase) at the joint position q (rad); exactly 1
 * where ripple_a == 0. Source: the position-dependent torque of harmonic drives (Tuttle & Seering 1996; Taghirad
 * & Belanger 1998), one harmonic of the position. Python: plant.ripple.FrictionRipple. */
double plant_ripple(const plant_params *p, double q);

/* plant_target at the joint position q (rad): plant_target(p, w, sgn)*plant_ripple(p, q) (ripple_a == 0: plant_target
 * itself). LuGre: the rippled level g(w)*R(q). N*m. Python: plant.rows.plant_target (argument q). */
double plant_target_at(const plant_params *p, double w, double q, double sgn);

/* State of steady motion at velocity w0 (rad/s) into *s: w = w0; q = 0 (the joint position, rad); s = F(w0)
 * (lagged models, eq. 3 with the levels of the direction of w0; 0 at rest) or the LuGre deflection
 * sgn(w0)*g(w0)/sigma0 (0 at rest), both times R(0) with a ripple; aux = p->key where tau == 0 (lagged), else
 * NaN. Python: plant.rows.plant_state. */
void plant_steady_state(const plant_params *p, double w0, plant_state *s);

/* plant_steady_state of n plants: out[b] for p[b], b < n (arrays of n structs). Python: plant.rows.plant_states. */
void plant_steady_states(const plant_params *p, long n, double w0, plant_state *out);

/* 1 where the plant can be integrated over steps of dt (s): LuGre: sqrt(sigma0/J)*dt <= plant_lugre_stiff_max
 * (plant_lugre_stiff_max; the pre-sliding frequency, Canudas de Wit et al. 1995); lagged models: J finite and > 0, tau finite and >= 0,
 * the levels (Fc, Fs - Fc, sigma per direction), Vs, delta, Fs_stick, dv finite; both: the ripple ripple_a == 0 or
 * 0 < ripple_a < 1 with ripple_n > 0 finite and ripple_phase finite. Else 0. Python:
 * plant.rows.check_integrable / integrable_rows. */
int plant_integrable(const plant_params *p, double dt);

/* ok[b] = plant_integrable(&p[b], dt) for b < n. */
void plant_integrable_array(const plant_params *p, long n, double dt, int *ok);

/* Largest pre-sliding frequency times step, sqrt(sigma0/J)*dt, of a LuGre plant that plant_integrable accepts
 * (1e4; Python: plant.rows.LUGRE_STIFF_MAX). */
extern const double plant_lugre_stiff_max;

#endif
