/* vmesh's direction-only work reused across calls (models/vmesh/vmesh_opacity.h, issue 15): the
 * C build keeps the last two directions' views per thread, and a view asked again (a light's)
 * remembers its cell/sub-cell overlap ratios. A view reused for the wrong direction, a slot
 * overwritten while in use or a remembered ratio for the wrong pair would change opacities; so
 * every answer of an interleaved sequence (a shadow direction repeated between changing primary directions, as the tracer asks,
 * plus repeats, opposite signs, -0.0 and non-unit lengths) is compared, bit for bit, with the same
 * call made after both slots were filled with other directions (a view computed afresh). */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "rng.h"
#include "unit.h"
#include "vmesh_opacity.h"

static float fresh(const vmesh_record *r, vec3 dir)
{
    /* Two other directions first, each asked twice: both slots now hold views of something else
     * (a view asked twice keeps its ratios and is not pushed out by a view asked once, so a single
     * call each could leave the light's view, ratios and all, in place). */
    vmesh_record full;
    memset(&full, 0, sizeof full);
    memset(full.opacity, 255, sizeof full.opacity);
    for (int k = 0; k < 2; k++)
        (void)vmesh_opacity_along(&full, v3(0.123f, -0.456f, 0.789f));
    for (int k = 0; k < 2; k++)
        (void)vmesh_opacity_along(&full, v3(-0.9f, 0.1f, 0.2f));
    return vmesh_opacity_along(r, dir);
}

int main(void)
{
    rng g = rng_seed(15, 0);
    enum { RECORDS = 64, DIRS = 16, CALLS = 4000 };
    static vmesh_record rec[RECORDS];
    for (int i = 0; i < RECORDS; i++) {
        memset(&rec[i], 0, sizeof rec[i]);
        for (int s = 0; s < VMESH_SUBCELLS; s++)
            rec[i].opacity[s] = rng_float(&g) < 0.4f ? 0 : (unsigned char)(1 + (int)(254.0f * rng_float(&g)));
    }
    vec3 dirs[DIRS];
    for (int k = 0; k < DIRS - 4; k++)
        dirs[k] = v3(2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f);
    dirs[DIRS - 4] = v3(0.0f, 0.0f, 1.0f);
    dirs[DIRS - 3] = v3(-0.0f, 0.0f, 1.0f); /* other bits, same direction */
    dirs[DIRS - 2] = v3_scale(dirs[0], -1.0f);
    dirs[DIRS - 1] = v3_scale(dirs[0], 3.0f);
    vec3 light = v3(0.45f, 1.0f, 0.55f);
    int mismatches = 0, calls = 0;
    float got[CALLS];
    vec3 asked[CALLS];
    int which[CALLS];
    /* The tracer's pattern: a primary direction, then a run of the light's, now and then a repeat. */
    for (int c = 0; c < CALLS; c++) {
        int u = (int)(rng_float(&g) * 4.0f);
        vec3 d = u == 0 ? dirs[(int)(rng_float(&g) * DIRS) % DIRS] : (u == 3 && c ? asked[c - 1] : light);
        int r = (int)(rng_float(&g) * RECORDS) % RECORDS;
        asked[c] = d;
        which[c] = r;
        got[c] = vmesh_opacity_along(&rec[r], d);
        calls++;
    }
    for (int c = 0; c < CALLS; c++) {
        float want = fresh(&rec[which[c]], asked[c]);
        mismatches += memcmp(&want, &got[c], sizeof want) != 0;
    }
    char name[160];
    snprintf(name, sizeof name, "reused views give the fresh answers, bit for bit (%d calls, %d differ)", calls,
             mismatches);
    CHECK(name, mismatches == 0);
    /* The normaliser's nearest-centre search (SSE in the C build) against the scalar loop, bit for
     * bit, over random directions, the axes and a NaN direction. */
    int den_bad = 0;
    for (int k = 0; k < 2000; k++) {
        vec3 d = k < 3 ? v3(k == 0, k == 1, k == 2)
                       : (k == 3 ? v3(NAN, 0.0f, 1.0f)
                                 : v3(2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f, 2.0f * rng_float(&g) - 1.0f));
        vmesh_view w;
        vmesh_view_setup(d, &w);
        float rc = 0.5f * w.cell, den = 0.0f;
        for (int cy = 0; cy < 2; cy++)
            for (int cx = 0; cx < 4; cx++) {
                float u = -w.half_side + ((float)cx + 0.5f) * w.cell, v = -w.half_side + ((float)cy + 0.5f) * w.cell;
                float dmin2 = 1e30f;
                for (int s = 0; s < VMESH_SUBCELLS; s++) {
                    float du = w.pu[s] - u, dv = w.pv[s] - v, d2 = du * du + dv * dv;
                    dmin2 = d2 < dmin2 ? d2 : dmin2;
                }
                den += 2.0f * (dmin2 <= w.near2 ? 1.0f
                                                : vmesh_disk_overlap(VMESH_RS, rc, sqrtf(dmin2)) * w.inv_cell_disk);
            }
        den_bad += memcmp(&den, &w.den, sizeof den) != 0;
    }
    snprintf(name, sizeof name, "the normaliser equals the scalar loop's, bit for bit (2000 directions, %d differ)",
             den_bad);
    CHECK(name, den_bad == 0);
    /* The direction itself must matter (else the check above proves nothing). */
    vmesh_record one;
    memset(&one, 0, sizeof one);
    one.opacity[(0 * 3 + 1) * 3 + 2] = 255;
    float a = vmesh_opacity_along(&one, v3(0.0f, 0.0f, 1.0f)), b = vmesh_opacity_along(&one, v3(1.0f, 0.3f, 0.2f));
    CHECK("a single sub-cell's opacity depends on the direction", a != b);
    CHECK("a reused view: the same direction again gives the same answer",
          vmesh_opacity_along(&one, v3(0.0f, 0.0f, 1.0f)) == a);
    return unit_exit();
}
