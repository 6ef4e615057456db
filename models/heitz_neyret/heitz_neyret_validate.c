/* What a `heitz-neyret` record (hn_record.h) may hold: the model's vx_model.validate_record
 * (heitz_neyret.c names it). */
#include <math.h>
#include <stdio.h>

#include "hn_host.h"

/* A half float that is infinite or NaN (exponent all ones): hn_float_to_half never writes one. */
static int half_is_special(unsigned short h) { return (h & 0x7c00u) == 0x7c00u; }

static int bad(char *why, size_t why_size, const char *field, const char *fmt, double v)
{
    char what[160];
    snprintf(what, sizeof what, fmt, v);
    snprintf(why, why_size, "%s: %s", field, what);
    return -1;
}

/* The encoder (hn_encode) clamps every snorm to [-1, 1] (never the most negative code), saturates
 * halves at 65504, writes variances as non-negative and zeroes the spare bytes. h is only required
 * to be finite: it is the mean plane distance from the cell's centre, within the cell in exact
 * arithmetic, but a cell far from the origin and tiny against float spacing there gets an h of
 * several edges from rounding alone (tests/unit_models.c's "far and tiny" voxel), and a large h
 * only moves the plane out of the element. */
int hn_validate_record(const void *record, const vx_record_context *c, char *why, size_t why_size)
{
    (void)c;
    const hn_record *r = record;
    if (!isfinite(r->h))
        return bad(why, why_size, "h", "%g (expected a finite distance)", (double)r->h);
    double len2 = 0.0;
    for (int k = 0; k < 3; k++) {
        if (r->n[k] == -32768)
            return bad(why, why_size, "n", "a component is -32768 (expected -32767..32767)", 0);
        len2 += ((double)r->n[k] / 32767.0) * ((double)r->n[k] / 32767.0);
    }
    if (len2 > 1.0 + 1e-3) /* a mean of unit normals, or a unit axis */
        return bad(why, why_size, "n", "length %g (expected at most 1)", sqrt(len2));
    if (half_is_special(r->var_h) || (r->var_h & 0x8000u))
        return bad(why, why_size, "var_h", "half 0x%04x (expected a finite value >= 0)", r->var_h);
    if (half_is_special(r->var_n) || (r->var_n & 0x8000u))
        return bad(why, why_size, "var_n", "half 0x%04x (expected a finite value >= 0)", r->var_n);
    if (half_is_special(r->area))
        return bad(why, why_size, "area", "half 0x%04x (expected a finite value)", r->area);
    for (int k = 0; k < 3; k++)
        if (r->as[k] == -128)
            return bad(why, why_size, "as", "a component is -128 (expected -127..127)", 0);
    if (r->psi == -128)
        return bad(why, why_size, "psi", "-128 (expected -127..127)", 0);
    if (r->spare[0] | r->spare[1])
        return bad(why, why_size, "spare", "non-zero (expected 0: reserved)", 0);
    return 0;
}
