/* aff_gate.c -- the plausibility gates (see aff_gate.h). */
#include <stddef.h>
#include <string.h>
#include "aff_gate.h"

aff_gate_config aff_gate_default_config(void)
{
    aff_gate_config c;
    c.max_step = (aff_real)INFINITY;
    c.n_sigma = (aff_real)8.0;
    c.alpha = (aff_real)0.01;
    c.max_consecutive = 20;
    return c;
}

aff_error aff_gate_check_config(const aff_gate_config *cfg)
{
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if (!(cfg->max_step == (aff_real)INFINITY || aff_nonnegative(cfg->max_step)))
        return AFF_ERR_GATE_MAX_STEP;
    if (!aff_positive(cfg->n_sigma))
        return AFF_ERR_GATE_N_SIGMA;
    if (!(cfg->alpha > 0 && cfg->alpha <= 1))
        return AFF_ERR_GATE_ALPHA;
    if (cfg->max_consecutive < 1)
        return AFF_ERR_GATE_MAX_CONSECUTIVE;
    return AFF_OK;
}

aff_error aff_gate_init(aff_gate *g, const aff_gate_config *cfg)
{
    aff_error e = g == NULL ? AFF_ERR_NULL : aff_gate_check_config(cfg);
    if (e != AFF_OK)
        return e;
    memset(g, 0, sizeof *g);
    g->max_step = cfg->max_step;
    g->n_sigma = cfg->n_sigma;
    g->alpha = cfg->alpha;
    g->max_consecutive = cfg->max_consecutive;
    g->last = 0;
    g->has_last = 0;
    g->scale = 0;
    g->n_held = 0;
    g->n_rejected = 0;
    g->n_nonfinite = 0;
    g->n_outliers = 0;
    return AFF_OK;
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
    aff_real d = AFF_FABS(x - g->last); /* x - last = -(last - x) exactly */
    aff_real bound = g->max_step + g->n_sigma * g->scale;
    if (g->n_held > 0) /* widened after held samples; times 1 exactly otherwise, so not multiplied */
        bound *= (aff_real)1.0 + (aff_real)g->n_held;
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

aff_range_gate_config aff_range_gate_default_config(void)
{
    aff_range_gate_config c;
    c.x_max = (aff_real)INFINITY;
    c.factor = (aff_real)100.0;
    c.floor = 0;
    c.memory = (aff_real)10000.0;
    c.max_consecutive = 20;
    return c;
}

aff_error aff_range_gate_check_config(const aff_range_gate_config *cfg)
{
    if (cfg == NULL)
        return AFF_ERR_NULL;
    if (!aff_positive_or_inf(cfg->x_max))
        return AFF_ERR_RANGE_GATE_X_MAX;
    if (!(isfinite(cfg->factor) && cfg->factor > 1))
        return AFF_ERR_RANGE_GATE_FACTOR;
    if (!aff_nonnegative(cfg->floor))
        return AFF_ERR_RANGE_GATE_FLOOR;
    if (!aff_positive(cfg->memory))
        return AFF_ERR_RANGE_GATE_MEMORY;
    if (cfg->max_consecutive < 1)
        return AFF_ERR_RANGE_GATE_MAX_CONSECUTIVE;
    return AFF_OK;
}

aff_error aff_range_gate_init(aff_range_gate *g, const aff_range_gate_config *cfg)
{
    aff_error e = g == NULL ? AFF_ERR_NULL : aff_range_gate_check_config(cfg);
    if (e != AFF_OK)
        return e;
    memset(g, 0, sizeof *g);
    g->x_max = cfg->x_max;
    g->factor = cfg->factor;
    g->floor = cfg->floor;
    g->decay = AFF_EXP(-(aff_real)1.0 / cfg->memory);
    g->max_consecutive = cfg->max_consecutive;
    g->env = 0;
    g->n_held = 0;
    g->n_rejected = 0;
    return AFF_OK;
}

int aff_range_gate_ok(const aff_range_gate *g, aff_real x)
{
    if (!isfinite(x))
        return 0;
    aff_real ax = AFF_FABS(x);
    if (ax > g->x_max)
        return 0;
    aff_real ref = g->env > g->floor ? g->env : g->floor;
    /* within the relative bound (the common case, so tested first), or no scale yet, or the signal really moved */
    return ax <= g->factor * ref || ref == 0 || g->n_held >= g->max_consecutive;
}

void aff_range_gate_commit(aff_range_gate *g, aff_real x, int ok)
{
    if (ok) {
        aff_real ax = AFF_FABS(x);
        aff_real e = g->decay * g->env;
        g->env = ax > e ? ax : e;
        g->n_held = 0;
    } else {
        g->n_held = aff_count_up(g->n_held);
        g->n_rejected = aff_count_up(g->n_rejected);
    }
}
