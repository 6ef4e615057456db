/* vmesh's direction-only work reused across calls (models/vmesh/vmesh_opacity.h, issue 15): the
 * C build keeps views per thread in a direct-mapped table (vmesh_view_of), and a view asked again
 * remembers its cell/sub-cell overlap ratios. A view reused for the wrong direction, a slot
 * overwritten while in use or a remembered ratio for the wrong pair would change opacities; so
 * every answer of an interleaved sequence (a shadow direction repeated between primary directions
 * that come back, as the tracer asks them per view tile, more of them than the table has slots so
 * that directions share slots, plus repeats, opposite signs, -0.0 and non-unit lengths) is
 * compared, bit for bit, with the answer computed afresh from the scalar definition.
 *
 * The C build's SSE paths (vmesh_opacity_sse.h) against the scalar code they stand for (the
 * definition, and the OpenCL build's code), bit for bit, piece by piece: acos, the disk overlap,
 * the projected centres, the normaliser and the cells' sum, the last with fresh views and with
 * views that remember their ratios (empty, or part filled by the scalar code). */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rng.h"
#include "unit.h"
#include "vmesh_opacity.h"

/* vmesh_opacity_along from a view set up here, nothing kept (the scalar definition's cells). */
static float fresh(const vmesh_record *r, vec3 dir)
{
    int order[VMESH_SUBCELLS], count = vmesh_sorted_subcells(r, order);
    if (!count)
        return 0.0f;
    vmesh_view w;
    vmesh_view_setup(dir, &w);
    float num = vmesh_cells_scalar(r, order, count, &w);
    return w.den > 0.0f ? vx_fminf(num / w.den, 1.0f) : 0.0f;
}

#ifdef VX_SSE
static int same_bits(float a, float b) { return memcmp(&a, &b, sizeof a) == 0; }

static float lane(__m128 v, int k)
{
    float f[4];
    _mm_storeu_ps(f, v);
    return f[k];
}

static vec3 random_dir(rng *g)
{
    return v3(2.0f * rng_float(g) - 1.0f, 2.0f * rng_float(g) - 1.0f, 2.0f * rng_float(g) - 1.0f);
}

/* A view that remembers its ratios, none of them known yet. */
static void remembering(vmesh_view *w)
{
    w->ratios = 1;
    for (int s = 0; s < VMESH_SUBCELLS; s++)
        for (int c = 0; c < 16; c++)
            w->ratio[s][c] = NAN;
}

static void sse_checks(rng *g)
{
    char name[200];
    /* acos: every 127th float of [0, 1] with both signs, and the branch points. */
    long acos_n = 0, acos_bad = 0;
    float special[] = {0.0f, -0.0f, 0.5f, -0.5f, nextafterf(0.5f, 1.0f), nextafterf(-0.5f, -1.0f), 1.0f, -1.0f};
    for (uint32_t bits = 0; bits <= 0x3F800000u + 8u; bits += bits < 0x3F800000u ? 127u : 1u) {
        float x[4];
        for (int k = 0; k < 4; k++) {
            uint32_t b = bits > 0x3F800000u ? 0 : bits;
            memcpy(&x[k], &b, sizeof x[k]);
            x[k] = k & 1 ? -x[k] : x[k];
        }
        if (bits > 0x3F800000u)
            for (int k = 0; k < 4; k++)
                x[k] = special[(bits - 0x3F800001u + (uint32_t)k) % 8u];
        __m128 got = vx_acosf4(_mm_loadu_ps(x));
        for (int k = 0; k < 4; k++, acos_n++)
            acos_bad += !same_bits(lane(got, k), vx_acosf(x[k]));
    }
    snprintf(name, sizeof name, "vx_acosf4 equals vx_acosf, bit for bit (%ld arguments in [-1, 1], %ld differ)", acos_n,
             acos_bad);
    CHECK(name, acos_n > 30000000 && acos_bad == 0);

    /* The disk overlap: random radii and distances, the view's own radii, and the branch points
     * (apart, tangent, contained, concentric, d2 = 0, NaN, radii <= 0). */
    long ov_n = 0, ov_bad = 0;
    for (int i = 0; i < 200000; i++) {
        float r1 = i % 3 == 0 ? VMESH_RS : rng_float(g), r2 = i % 3 == 0 ? 0.08f + 0.14f * rng_float(g) : rng_float(g);
        if (i % 97 == 0)
            r1 = i % 2 ? 0.0f : -0.25f;
        float d2[4];
        for (int k = 0; k < 4; k++) {
            float d = 1.2f * (r1 + r2) * rng_float(g);
            int edge = (int)(rng_float(g) * 8.0f);
            d = edge == 0 ? r1 + r2 : edge == 1 ? fabsf(r1 - r2) : edge == 2 ? 0.0f : d;
            d2[k] = edge == 3 && i % 5 == 0 ? NAN : d * d;
        }
        __m128 got = vmesh_disk_overlap4(r1, r2, _mm_loadu_ps(d2));
        for (int k = 0; k < 4; k++, ov_n++)
            ov_bad += !same_bits(lane(got, k), vmesh_disk_overlap(r1, r2, sqrtf(d2[k])));
    }
    snprintf(name, sizeof name, "vmesh_disk_overlap4 equals vmesh_disk_overlap, bit for bit (%ld cases, %ld differ)",
             ov_n, ov_bad);
    CHECK(name, ov_bad == 0);

    /* The projected centres and the normaliser: random directions, the axes, the diagonals, a NaN
     * direction. */
    int view_bad = 0, den_bad = 0;
    for (int k = 0; k < 4000; k++) {
        vec3 d = k < 3 ? v3(k == 0, k == 1, k == 2)
                       : k == 3 ? v3(NAN, 0.0f, 1.0f) : k < 8 ? v3(1.0f, k & 1 ? 1.0f : -1.0f, k & 2 ? 1.0f : 0.0f)
                                                      : random_dir(g);
        vmesh_view w;
        vmesh_view_setup(d, &w);
        vec3 n = v3_normalize_or(d, v3(0.0f, 0.0f, 1.0f)), t, b;
        v3_basis(n.z < 0.0f ? v3_scale(n, -1.0f) : n, &t, &b);
        float pu[VMESH_SUBCELLS + 1], pv[VMESH_SUBCELLS + 1], su[VMESH_SUBCELLS + 1], sv[VMESH_SUBCELLS + 1];
        vmesh_project_scalar(t, b, pu, pv);
        vmesh_project_sse(t, b, su, sv);
        view_bad += memcmp(pu, su, VMESH_SUBCELLS * sizeof *pu) != 0 || memcmp(pv, sv, VMESH_SUBCELLS * sizeof *pv) != 0 ||
                    memcmp(pu, w.pu, VMESH_SUBCELLS * sizeof *pu) != 0;
        float want = vmesh_normaliser_scalar(&w);
        den_bad += !same_bits(vmesh_normaliser_sse(&w), want) || !same_bits(w.den, want);
    }
    snprintf(name, sizeof name, "the SSE projected centres equal the scalar loop's, bit for bit (4000 directions, %d differ)",
             view_bad);
    CHECK(name, view_bad == 0);
    snprintf(name, sizeof name, "the SSE normaliser equals the scalar loop's, bit for bit (4000 directions, %d differ)",
             den_bad);
    CHECK(name, den_bad == 0);

    /* The sort by ranks: the scalar insertion sort's count and order on records with random
     * opacities, few distinct values (many ties), all opaque, none, one; each record alone in its
     * own allocation (the loads must stay inside it: AddressSanitizer's run would see them leave),
     * and the order checked against its definition too (descending, ties by index, a permutation of
     * the non-empty sub-cells). */
    int sorts = 0, sort_bad = 0, ties = 0;
    for (int k = 0; k < 20000; k++) {
        vmesh_record *r = malloc(sizeof *r);
        if (!r) {
            CHECK("memory for a record to sort", 0);
            return;
        }
        memset(r, 0xA5, sizeof *r); /* the fields around the opacities are not zero */
        int kind = k % 6;
        for (int s = 0; s < VMESH_SUBCELLS; s++) {
            float u = rng_float(g);
            r->opacity[s] = kind == 0   ? (unsigned char)(256.0f * u)
                            : kind == 1 ? (unsigned char)(u < 0.3f ? 0 : (u < 0.6f ? 17 : (u < 0.9f ? 255 : 128)))
                            : kind == 2 ? 255
                            : kind == 3 ? 0
                            : kind == 4 ? (unsigned char)(s == k % VMESH_SUBCELLS ? 1 + k % 255 : 0)
                                        : (unsigned char)(u < 0.5f ? 0 : 1 + (int)(3.0f * rng_float(g)));
        }
        int want[VMESH_SUBCELLS], got[VMESH_SUBCELLS];
        for (int s = 0; s < VMESH_SUBCELLS; s++)
            want[s] = got[s] = -1;
        int nw = vmesh_sorted_subcells(r, want), ng = vmesh_sorted_subcells_sse(r, got);
        int bad = nw != ng || memcmp(want, got, sizeof want) != 0;
        int held = 0, seen = 0;
        for (int s = 0; s < VMESH_SUBCELLS; s++)
            held += r->opacity[s] != 0;
        bad |= ng != held;
        for (int i = 0; i < ng && !bad; i++) {
            int a = got[i];
            bad |= a < 0 || a >= VMESH_SUBCELLS || !r->opacity[a] || ((seen >> a) & 1);
            if (bad)
                break;
            seen |= 1 << a;
            if (i > 0) {
                int b = got[i - 1];
                bad |= r->opacity[b] < r->opacity[a] || (r->opacity[b] == r->opacity[a] && b > a);
                ties += r->opacity[b] == r->opacity[a];
            }
        }
        sort_bad += bad;
        sorts++;
        free(r);
    }
    snprintf(name, sizeof name,
             "vmesh_sorted_subcells_sse gives the insertion sort's count and order (%d records, %d ties, %d differ)",
             sorts, ties, sort_bad);
    CHECK(name, sorts == 20000 && ties > 10000 && sort_bad == 0);

    /* The cells' sum: records with random opacities and ties, all opaque, one sub-cell, faint
     * ones; each with a fresh view, a remembering view asked first by the SSE code, and one part
     * filled by the scalar code for another record. */
    int cells_n = 0, cells_bad = 0, nonzero = 0;
    for (int k = 0; k < 3000; k++) {
        vmesh_record r;
        memset(&r, 0, sizeof r);
        int kind = k % 5;
        for (int s = 0; s < VMESH_SUBCELLS; s++) {
            float u = rng_float(g);
            r.opacity[s] = kind == 0 ? (u < 0.4f ? 0 : (unsigned char)(1 + (int)(254.0f * rng_float(g))))
                           : kind == 1 ? 255
                           : kind == 2 ? (u < 0.5f ? 0 : (u < 0.8f ? 255 : 128))
                           : kind == 3 ? (u < 0.8f ? 0 : (unsigned char)(1 + (int)(8.0f * rng_float(g))))
                                       : 0;
        }
        if (kind == 4)
            r.opacity[(int)(rng_float(g) * VMESH_SUBCELLS) % VMESH_SUBCELLS] = 200;
        int order[VMESH_SUBCELLS], count = vmesh_sorted_subcells(&r, order);
        if (!count)
            continue;
        vec3 d = k < 3 ? v3(k == 0, k == 1, k == 2) : random_dir(g);
        vmesh_view fresh_view, memo_view, part_view;
        vmesh_view_setup(d, &fresh_view);
        memo_view = fresh_view;
        remembering(&memo_view);
        part_view = memo_view;
        vmesh_record other;
        memset(&other, 0, sizeof other);
        for (int s = 0; s < VMESH_SUBCELLS; s += 2)
            other.opacity[s] = (unsigned char)(40 + 7 * s);
        int other_order[VMESH_SUBCELLS], other_count = vmesh_sorted_subcells(&other, other_order);
        (void)vmesh_cells_scalar(&other, other_order, other_count, &part_view);
        float want = vmesh_cells_scalar(&r, order, count, &fresh_view);
        float got[3] = {vmesh_cells_sse(&r, order, count, &fresh_view), vmesh_cells_sse(&r, order, count, &memo_view),
                        vmesh_cells_sse(&r, order, count, &part_view)};
        for (int v = 0; v < 3; v++)
            cells_bad += !same_bits(got[v], want);
        /* and the remembering view, filled by the SSE code, read by the scalar code */
        cells_bad += !same_bits(vmesh_cells_scalar(&r, order, count, &memo_view), want);
        cells_n++;
        nonzero += want > 0.0f;
    }
    snprintf(name, sizeof name,
             "vmesh_cells_sse equals vmesh_cells_scalar, bit for bit, fresh and remembering views (%d records, %d "
             "non-zero, %d differ)",
             cells_n, nonzero, cells_bad);
    CHECK(name, cells_n > 2000 && nonzero > cells_n / 2 && cells_bad == 0);
}
#endif

int main(void)
{
    rng g = rng_seed(15, 0);
    enum { RECORDS = 64, DIRS = 2 * VMESH_VIEW_SLOTS + 44, CALLS = 8000 };
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
    /* The direction itself must matter (else the check above proves nothing). */
    vmesh_record one;
    memset(&one, 0, sizeof one);
    one.opacity[(0 * 3 + 1) * 3 + 2] = 255;
    float a = vmesh_opacity_along(&one, v3(0.0f, 0.0f, 1.0f)), b = vmesh_opacity_along(&one, v3(1.0f, 0.3f, 0.2f));
    CHECK("a single sub-cell's opacity depends on the direction", a != b);
    CHECK("a reused view: the same direction again gives the same answer",
          vmesh_opacity_along(&one, v3(0.0f, 0.0f, 1.0f)) == a);
#ifdef VX_SSE
    sse_checks(&g);
#else
    CHECK("the C build runs vmesh's SSE paths (SSE4.1 on the x86-64-v2 target)", 0);
#endif
    return unit_exit();
}
