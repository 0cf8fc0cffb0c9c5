/* aff_gate.c -- the plausibility gates (see aff_gate.h). */
#include "aff_gate.h"

void aff_gate_init(aff_gate *g, aff_real max_step, aff_real n_sigma, aff_real alpha, long max_consecutive)
{
    g->max_step = max_step;
    g->n_sigma = n_sigma;
    g->alpha = alpha;
    g->max_consecutive = max_consecutive;
    g->last = 0;
    g->has_last = 0;
    g->scale = 0;
    g->n_held = 0;
    g->n_rejected = 0;
    g->n_nonfinite = 0;
    g->n_outliers = 0;
}

int aff_gate_check(aff_gate *g, aff_real x)
{
    if (!isfinite(x)) {
        g->n_rejected = aff_count_up(g->n_rejected);
        g->n_nonfinite = aff_count_up(g->n_nonfinite);
        g->n_held = aff_count_up(g->n_held);
        return 0;
    }
    if (!g->has_last) {
        g->last = x;
        g->has_last = 1;
        return 1;
    }
    aff_real d = x >= g->last ? x - g->last : g->last - x;
    aff_real bound = (g->max_step + g->n_sigma * g->scale) * ((aff_real)1.0 + (aff_real)g->n_held);
    if (d > bound) {
        if (g->n_held < g->max_consecutive) {
            g->n_rejected = aff_count_up(g->n_rejected);
            g->n_outliers = aff_count_up(g->n_outliers);
            g->n_held = aff_count_up(g->n_held);
            return 0;
        }
    } else {
        g->scale += g->alpha * (d - g->scale);
    }
    g->last = x;
    g->n_held = 0;
    return 1;
}

void aff_range_gate_init(aff_range_gate *g, aff_real x_max, aff_real factor, aff_real floor, aff_real decay,
                         long max_consecutive)
{
    g->x_max = x_max;
    g->factor = factor;
    g->floor = floor;
    g->decay = decay;
    g->max_consecutive = max_consecutive;
    g->env = 0;
    g->n_held = 0;
    g->n_rejected = 0;
}

int aff_range_gate_ok(const aff_range_gate *g, aff_real x)
{
    if (!isfinite(x))
        return 0;
    aff_real ax = x >= 0 ? x : -x;
    if (ax > g->x_max)
        return 0;
    aff_real ref = g->env > g->floor ? g->env : g->floor;
    if (ref == 0 || g->n_held >= g->max_consecutive) /* no scale yet, or the signal really moved */
        return 1;
    return ax <= g->factor * ref;
}

void aff_range_gate_commit(aff_range_gate *g, aff_real x, int ok)
{
    if (ok) {
        aff_real ax = x >= 0 ? x : -x;
        aff_real e = g->decay * g->env;
        g->env = ax > e ? ax : e;
        g->n_held = 0;
    } else {
        g->n_held = aff_count_up(g->n_held);
        g->n_rejected = aff_count_up(g->n_rejected);
    }
}
