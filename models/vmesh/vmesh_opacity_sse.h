/* vmesh_cells (vmesh_opacity.h) with a row of four window cells per SSE vector, for the C build
 * (SSE4.1: the project's x86-64-v2 target). Why: the scalar loop is most of a primary evaluation
 * (about 1.4 of its 1.65 us on random records): one branchy d2 test per cell and sub-cell, and about
 * 20 disk overlaps. Here a sub-cell is tested against a row's four cells at once and the overlaps
 * come four at a time.
 *
 * The same bits as vmesh_cells_scalar (tests/unit_vmesh_view.c compares them):
 *  - each lane evaluates the scalar expressions in their order (the cell centres, d2, the far and
 *    near tests, vmesh_disk_overlap through vx_acosf4, the ratio, opacity x ratio): SSE's
 *    single-precision operations round as the scalar ones do on this target, and lanes that take
 *    another branch of the scalar code get that branch's value by a blend;
 *  - a cell is updated only while the scalar loop would still look (`active`: the sub-cell's
 *    opacity above the cell's best; the opacities come most opaque first, so a cell that stops
 *    stays stopped), by the scalar comparison prod > best ? prod : best (maxps(prod, best));
 *  - the 16 bests are summed in the scalar loop's order.
 * A view that remembers its ratios (a light's) keeps them per sub-cell and row here, computed for
 * the whole row the first time any of its four is missing (a row the scalar code filled in part is
 * computed again: the same values). A fresh view (a voxel's own direction toward the camera) queues
 * the cells that need an overlap across rows and sub-cells, and computes them four at a time
 * (vmesh_cells_fresh_sse says why that is the same value). */
#ifndef VX_VMESH_OPACITY_SSE_H
#define VX_VMESH_OPACITY_SSE_H

#include "portable_acos_sse.h"
#include "vec_sse.h"

/* vmesh_disk_overlap(r1, r2, sqrtf(d2)) per lane. */
static inline __m128 vmesh_disk_overlap4(float r1, float r2, __m128 d2)
{
    if (!(r1 > 0.0f) || !(r2 > 0.0f))
        return _mm_setzero_ps();
    float rmin = r1 < r2 ? r1 : r2, rmax = r1 < r2 ? r2 : r1;
    const __m128 one = _mm_set1_ps(1.0f), minus_one = _mm_set1_ps(-1.0f);
    __m128 d = _mm_sqrt_ps(d2); /* >= 0 or NaN: fabsf changes nothing */
    __m128 apart = _mm_cmpnlt_ps(d, _mm_set1_ps(r1 + r2));
    __m128 contained = _mm_cmple_ps(d, _mm_set1_ps(rmax - rmin));
    __m128 dd = _mm_mul_ps(d, d), two_d = _mm_mul_ps(_mm_set1_ps(2.0f), d);
    __m128 r1r1 = _mm_set1_ps(r1 * r1), r2r2 = _mm_set1_ps(r2 * r2);
    __m128 x1 = _mm_div_ps(_mm_sub_ps(_mm_add_ps(dd, r1r1), r2r2), _mm_mul_ps(two_d, _mm_set1_ps(r1)));
    __m128 x2 = _mm_div_ps(_mm_sub_ps(_mm_add_ps(dd, r2r2), r1r1), _mm_mul_ps(two_d, _mm_set1_ps(r2)));
    /* x < -1 ? -1 : (x > 1 ? 1 : x); minps(x, 1) is x < 1 ? x : 1, the same for every non-NaN x, and
     * the NaN lanes (d = 0) are contained ones, replaced below. */
    x1 = _mm_max_ps(_mm_min_ps(x1, one), minus_one);
    x2 = _mm_max_ps(_mm_min_ps(x2, one), minus_one);
    __m128 seg1 = _mm_sub_ps(vx_acosf4(x1), _mm_mul_ps(x1, _mm_sqrt_ps(_mm_sub_ps(one, _mm_mul_ps(x1, x1)))));
    __m128 seg2 = _mm_sub_ps(vx_acosf4(x2), _mm_mul_ps(x2, _mm_sqrt_ps(_mm_sub_ps(one, _mm_mul_ps(x2, x2)))));
    __m128 small = _mm_set1_ps(VX_PI * rmin * rmin);
    __m128 a = _mm_min_ps(_mm_add_ps(_mm_mul_ps(r1r1, seg1), _mm_mul_ps(r2r2, seg2)), small); /* a < small ? a : small */
    return _mm_andnot_ps(apart, _mm_blendv_ps(a, small, contained));
}

/* The 27 sub-cell centres (and the pad after them) projected onto the window's axes t and b, four
 * at a time: v3_dot(c, t) per lane (vx_dot3_ps). The lattice's coordinates are
 * ((float)i - 1.0f) / 3.0f, as vmesh_view_setup's scalar loop computes them (folded by the compiler,
 * which rounds as the run-time division does). */
#define VMESH_THIRD(i) (((float)(i) - 1.0f) / 3.0f)
#define VMESH_LATTICE_9(i) VMESH_THIRD(i), VMESH_THIRD(i), VMESH_THIRD(i), VMESH_THIRD(i), VMESH_THIRD(i), \
    VMESH_THIRD(i), VMESH_THIRD(i), VMESH_THIRD(i), VMESH_THIRD(i)
#define VMESH_LATTICE_3(i) VMESH_THIRD(i), VMESH_THIRD(i), VMESH_THIRD(i)
#define VMESH_LATTICE_1 VMESH_THIRD(0), VMESH_THIRD(1), VMESH_THIRD(2)
static inline void vmesh_project_sse(vec3 t, vec3 b, float *pu, float *pv)
{
    /* Sub-cell s = (i * 3 + j) * 3 + k sits at (x_i, y_j, z_k); entry 27 is a pad at the origin. */
    static const float x[VMESH_SUBCELLS + 1] = {VMESH_LATTICE_9(0), VMESH_LATTICE_9(1), VMESH_LATTICE_9(2), 0.0f};
    static const float y[VMESH_SUBCELLS + 1] = {VMESH_LATTICE_3(0), VMESH_LATTICE_3(1), VMESH_LATTICE_3(2),
                                                VMESH_LATTICE_3(0), VMESH_LATTICE_3(1), VMESH_LATTICE_3(2),
                                                VMESH_LATTICE_3(0), VMESH_LATTICE_3(1), VMESH_LATTICE_3(2), 0.0f};
    static const float z[VMESH_SUBCELLS + 1] = {VMESH_LATTICE_1, VMESH_LATTICE_1, VMESH_LATTICE_1, VMESH_LATTICE_1,
                                                VMESH_LATTICE_1, VMESH_LATTICE_1, VMESH_LATTICE_1, VMESH_LATTICE_1,
                                                VMESH_LATTICE_1, 0.0f};
    for (int s = 0; s < VMESH_SUBCELLS + 1; s += 4) {
        __m128 cx = _mm_loadu_ps(&x[s]), cy = _mm_loadu_ps(&y[s]), cz = _mm_loadu_ps(&z[s]);
        _mm_storeu_ps(&pu[s], vx_dot3_ps(t.x, t.y, t.z, cx, cy, cz));
        _mm_storeu_ps(&pv[s], vx_dot3_ps(b.x, b.y, b.z, cx, cy, cz));
    }
}

/* The normaliser of vmesh_view_setup (w's window and projected centres set): per cell of the first
 * two rows, the nearest centre's d2 four centres at a time (a minimum is exact; minps(d2, m)
 * returns m when either is NaN, as the scalar d2 < dmin2 ? d2 : dmin2 keeps dmin2), then the eight
 * ratios four at a time, summed in the scalar loop's order. */
static inline float vmesh_normaliser_sse(const vmesh_view *w)
{
    float dmin2[8], ratio[8], den = 0.0f;
    for (int cy = 0; cy < 2; cy++)
        for (int cx = 0; cx < 4; cx++) {
            float u = vmesh_cell_centre(w, cx), v = vmesh_cell_centre(w, cy);
            __m128 U = _mm_set1_ps(u), V = _mm_set1_ps(v), m = _mm_set1_ps(1e30f);
            for (int s = 0; s < VMESH_SUBCELLS + 1; s += 4) {
                __m128 du = _mm_sub_ps(_mm_loadu_ps(&w->pu[s]), U), dv = _mm_sub_ps(_mm_loadu_ps(&w->pv[s]), V);
                m = _mm_min_ps(_mm_add_ps(_mm_mul_ps(du, du), _mm_mul_ps(dv, dv)), m);
            }
            m = _mm_min_ps(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(1, 0, 3, 2)));
            m = _mm_min_ps(m, _mm_shuffle_ps(m, m, _MM_SHUFFLE(2, 3, 0, 1)));
            dmin2[cy * 4 + cx] = _mm_cvtss_f32(m);
        }
    for (int h = 0; h < 8; h += 4) {
        __m128 d2 = _mm_loadu_ps(&dmin2[h]);
        __m128 r = _mm_mul_ps(vmesh_disk_overlap4(VMESH_RS, 0.5f * w->cell, d2), _mm_set1_ps(w->inv_cell_disk));
        _mm_storeu_ps(&ratio[h], _mm_blendv_ps(r, _mm_set1_ps(1.0f), _mm_cmple_ps(d2, _mm_set1_ps(w->near2))));
    }
    for (int c = 0; c < 8; c++)
        den += 2.0f * ratio[c];
    return den;
}

/* vmesh_cell_ratio for the four cells of row `cy` (centres u, v) with sub-cell s; the overlaps only
 * when a lane is between the near and far distances. */
static inline __m128 vmesh_row_ratio(const vmesh_view *w, int s, __m128 u, float v)
{
    __m128 du = _mm_sub_ps(_mm_set1_ps(w->pu[s]), u), dv = _mm_set1_ps(w->pv[s] - v);
    __m128 d2 = _mm_add_ps(_mm_mul_ps(du, du), _mm_mul_ps(dv, dv));
    __m128 beyond = _mm_cmpge_ps(d2, _mm_set1_ps(w->far2)), within = _mm_cmple_ps(d2, _mm_set1_ps(w->near2));
    __m128 ratio = _mm_setzero_ps();
    if (_mm_movemask_ps(_mm_or_ps(beyond, within)) != 0xF)
        ratio = _mm_mul_ps(vmesh_disk_overlap4(VMESH_RS, 0.5f * w->cell, d2), _mm_set1_ps(w->inv_cell_disk));
    return _mm_andnot_ps(beyond, _mm_blendv_ps(ratio, _mm_set1_ps(1.0f), within));
}

/* vmesh_sorted_subcells by ranks instead of insertion: sub-cell s goes to place
 * #{t : opacity t > opacity s} + #{t < s : opacity t = opacity s}, which is where the stable
 * descending insertion sort puts it (the same order: tests/unit_vmesh_view.c). Why: the insertion
 * sort's data-dependent branches were a tenth of a vmesh frame (a quarter of a light's memoised
 * evaluation, whose ratios are remembered); here each sub-cell costs two byte comparisons against
 * all 27 at once. The 27 opacities are read as bytes 0-15 and 11-26 (two loads inside the record),
 * one bit per sub-cell in a 27-bit word. */
static inline int vmesh_sorted_subcells_sse(const vmesh_record *r, int *order)
{
    const __m128i lo = _mm_loadu_si128((const __m128i *)(const void *)&r->opacity[0]);
    const __m128i hi = _mm_loadu_si128((const __m128i *)(const void *)&r->opacity[VMESH_SUBCELLS - 16]);
    const __m128i zero = _mm_setzero_si128();
#define VMESH_BITS27(l, h) \
    ((uint32_t)_mm_movemask_epi8(l) | ((uint32_t)_mm_movemask_epi8(h) >> (32 - VMESH_SUBCELLS)) << 16)
    /* Bits of the sub-cells holding opacity. */
    uint32_t held = ~VMESH_BITS27(_mm_cmpeq_epi8(lo, zero), _mm_cmpeq_epi8(hi, zero)) & ((1u << VMESH_SUBCELLS) - 1u);
    int count = __builtin_popcount(held);
    for (uint32_t left = held; left; left &= left - 1u) {
        int s = __builtin_ctz(left);
        __m128i a = _mm_set1_epi8((char)r->opacity[s]);
        /* opacity t > a (unsigned): the saturated t - a is not 0; equal: the bytes compare equal */
        uint32_t not_above = VMESH_BITS27(_mm_cmpeq_epi8(_mm_subs_epu8(lo, a), zero), _mm_cmpeq_epi8(_mm_subs_epu8(hi, a), zero));
        uint32_t equal = VMESH_BITS27(_mm_cmpeq_epi8(lo, a), _mm_cmpeq_epi8(hi, a));
        uint32_t above = ~not_above & ((1u << VMESH_SUBCELLS) - 1u);
        order[__builtin_popcount(above) + __builtin_popcount(equal & ((1u << s) - 1u))] = s;
    }
#undef VMESH_BITS27
    return count;
}

/* The overlaps a fresh view's cells wait for (vmesh_cells_fresh_sse), four to a vector: per entry
 * the window cell (cy * 4 + cx), its d2 to the sub-cell's centre and the sub-cell's opacity. */
typedef struct {
    float d2[4], a[4];
    int cell[4], n;
} vmesh_pending;

/* The waiting overlaps' products a x ratio, each kept by its cell as the scalar loop keeps it
 * (prod > best ? prod : best), in the order they were queued; the queue is then empty. Lanes past n
 * are computed on whatever they hold and not read. */
static inline void vmesh_pending_flush(const vmesh_view *w, vmesh_pending *q, float *best)
{
    __m128 ratio = _mm_mul_ps(vmesh_disk_overlap4(VMESH_RS, 0.5f * w->cell, _mm_loadu_ps(q->d2)),
                              _mm_set1_ps(w->inv_cell_disk));
    float prod[4];
    _mm_storeu_ps(prod, _mm_mul_ps(_mm_loadu_ps(q->a), ratio));
    for (int i = 0; i < q->n; i++) {
        float *b = &best[q->cell[i]];
        *b = prod[i] > *b ? prod[i] : *b;
    }
    q->n = 0;
}

/* vmesh_cells_sse for a view that does not remember its ratios (a voxel's own direction toward the
 * camera, used once). A cell's value is max(0, max over the sub-cells of opacity x ratio): each
 * product is rounded once and max is exact, so the order in which the products are taken does not
 * change it, and the scalar loop's break only skips products that cannot exceed the cell's best
 * (the next opacities are at most the best, and a ratio at most 1). So the cells between the near
 * and far distances of a sub-cell, the only ones whose ratio needs the two arc cosines, are queued
 * across rows and sub-cells and their overlaps computed four at a time, instead of one vector per row and sub-cell with 1.6 of its 4
 * lanes wanted on average (bunny 256^3: 2.57 M wanted lanes in 1.57 M overlaps a frame). A cell
 * looks at a sub-cell while that sub-cell's opacity is above its best so far, which with products
 * still queued is a lower bound of the scalar loop's best: at most some more products are queued,
 * never one fewer. The within cells' ratio is 1: their product is the opacity itself. */
static inline float vmesh_cells_fresh_sse(const vmesh_record *r, const int *order, int count, const vmesh_view *w)
{
    float centre[4], best[16] = {0};
    for (int c = 0; c < 4; c++)
        centre[c] = vmesh_cell_centre(w, c);
    const __m128 u = _mm_loadu_ps(centre), far2 = _mm_set1_ps(w->far2), near2 = _mm_set1_ps(w->near2);
    vmesh_pending q = {{0.0f}, {0.0f}, {0}, 0}; /* lanes past n: numbers whose results go unread */
    for (int o = 0; o < count; o++) {
        int s = order[o];
        float a = vmesh_decode_unorm(r->opacity[s]);
        __m128 A = _mm_set1_ps(a), du = _mm_sub_ps(_mm_set1_ps(w->pu[s]), u), du2 = _mm_mul_ps(du, du);
        /* The four rows without a branch each: which cells still look, the within ones updated,
         * the between ones as one 16-bit mask. */
        int looking = 0, between = 0;
        float d2s[16];
        for (int cy = 0; cy < 4; cy++) {
            __m128 row_best = _mm_loadu_ps(&best[4 * cy]);
            __m128 active = _mm_cmpgt_ps(A, row_best); /* the scalar loop's !(a <= best) */
            float dv = w->pv[s] - centre[cy];
            __m128 d2 = _mm_add_ps(du2, _mm_set1_ps(dv * dv));
            __m128 within = _mm_and_ps(_mm_cmple_ps(d2, near2), active);
            /* a x 1 is a: maxps(a, best) is the scalar a > best ? a : best */
            _mm_storeu_ps(&best[4 * cy], _mm_blendv_ps(row_best, _mm_max_ps(A, row_best), within));
            _mm_storeu_ps(&d2s[4 * cy], d2);
            looking |= _mm_movemask_ps(active);
            between |= _mm_movemask_ps(_mm_andnot_ps(_mm_or_ps(_mm_cmpge_ps(d2, far2), within), active)) << (4 * cy);
        }
        if (!looking)
            break;
        for (; between; between &= between - 1) {
            int c = __builtin_ctz((unsigned)between);
            q.d2[q.n] = d2s[c];
            q.a[q.n] = a;
            q.cell[q.n] = c;
            if (++q.n == 4)
                vmesh_pending_flush(w, &q, best);
        }
    }
    if (q.n)
        vmesh_pending_flush(w, &q, best);
    float num = 0.0f;
    for (int c = 0; c < 16; c++)
        num += best[c];
    return num;
}

/* vmesh_cells_sse for a view that remembers its ratios (a light's): per sub-cell and row, the four
 * ratios read, or computed for the whole row the first time any of them is missing. */
static inline float vmesh_cells_remembered_sse(const vmesh_record *r, const int *order, int count, vmesh_view *w)
{
    float centre[4];
    for (int c = 0; c < 4; c++)
        centre[c] = vmesh_cell_centre(w, c);
    const __m128 u = _mm_loadu_ps(centre);
    __m128 best[4];
    for (int cy = 0; cy < 4; cy++)
        best[cy] = _mm_setzero_ps();
    for (int o = 0; o < count; o++) {
        int s = order[o], looking = 0;
        __m128 a = _mm_set1_ps(vmesh_decode_unorm(r->opacity[s]));
        for (int cy = 0; cy < 4; cy++) {
            __m128 active = _mm_cmpgt_ps(a, best[cy]); /* the scalar loop's !(a <= best) */
            if (!_mm_movemask_ps(active))
                continue;
            looking = 1;
            float *row = &w->ratio[s][4 * cy];
            __m128 ratio = _mm_loadu_ps(row);
            if (_mm_movemask_ps(_mm_cmpunord_ps(ratio, ratio))) {
                ratio = vmesh_row_ratio(w, s, u, centre[cy]);
                _mm_storeu_ps(row, ratio);
            }
            __m128 prod = _mm_mul_ps(a, ratio);
            best[cy] = _mm_blendv_ps(best[cy], _mm_max_ps(prod, best[cy]), active);
        }
        if (!looking)
            break;
    }
    float b[16], num = 0.0f;
    for (int cy = 0; cy < 4; cy++)
        _mm_storeu_ps(&b[4 * cy], best[cy]);
    for (int c = 0; c < 16; c++)
        num += b[c];
    return num;
}

static inline float vmesh_cells_sse(const vmesh_record *r, const int *order, int count, vmesh_view *w)
{
    return w->ratios ? vmesh_cells_remembered_sse(r, order, count, w) : vmesh_cells_fresh_sse(r, order, count, w);
}

#endif
