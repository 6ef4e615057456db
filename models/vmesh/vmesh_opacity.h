/* `vmesh` directional opacity from the 3x3x3 subgrid (Brito et al. 2023, §3.4). Portable C (also
 * OpenCL C): no libc beyond <math.h>, no allocation, fixed-size arrays.
 *
 * The voxel is projected along the view direction onto a square window bounding its projection,
 * cut into 4x4 cells. Each sub-cell is replaced by its enclosing sphere, projected as a disk; each
 * window cell is represented by the disk inscribed in it (the paper's "circle enclosed by the
 * pixel"). A cell takes the largest opacity x (overlap area / cell-disk area) over the sub-cells.
 *
 * One deliberate change to "average of the 16 cells": the average is divided by the same average
 * computed for a voxel whose 27 opacities are all 1 (per cell, the overlap ratio of the nearest
 * sub-disk). The window is a square around a hexagon (up to 1/sqrt(2) of it empty when seen along a
 * face diagonal), and one disk covers an inner cell only in part, so the literal mean gives a solid
 * voxel 0.59 along (1,1,0) and 0.99 along an axis: walls would leak. The tracer applies the value
 * to rays that do cross the voxel, so it must be relative to the voxel's own projection; after the
 * division a solid voxel is 1 and a uniform opacity a is a from every direction, and empty cells
 * still count as empty. */
#ifndef VX_VMESH_OPACITY_H
#define VX_VMESH_OPACITY_H

#include "portable_acos.h"
#include "simd.h"
#include "shading.h"
#include "vmesh_record.h"

/* Area of the intersection of two disks of radii r1 and r2 whose centres are d apart: 0 when
 * apart or externally tangent, the smaller disk when contained (equal radii and concentric
 * included), otherwise the two circular segments r^2 (theta - sin theta cos theta), each
 * non-negative, so rounding never gives a negative area. */
VX_INLINE float vmesh_disk_overlap(float r1, float r2, float d)
{
    if (!(r1 > 0.0f) || !(r2 > 0.0f))
        return 0.0f;
    d = fabsf(d);
    /* Ternaries rather than fminf/fmaxf: the inputs are finite here, and in C those are libm calls
     * on the renderer's hottest path. */
    float rmin = r1 < r2 ? r1 : r2, rmax = r1 < r2 ? r2 : r1;
    if (!(d < r1 + r2))
        return 0.0f;
    if (d <= rmax - rmin)
        return VX_PI * rmin * rmin;
    float x1 = (d * d + r1 * r1 - r2 * r2) / (2.0f * d * r1), x2 = (d * d + r2 * r2 - r1 * r1) / (2.0f * d * r2);
    x1 = x1 < -1.0f ? -1.0f : (x1 > 1.0f ? 1.0f : x1);
    x2 = x2 < -1.0f ? -1.0f : (x2 > 1.0f ? 1.0f : x2);
    /* vx_acosf, not acosf: this is the render's hottest libm call (see portable_acos.h). */
    float a = r1 * r1 * (vx_acosf(x1) - x1 * sqrtf(1.0f - x1 * x1)) +
              r2 * r2 * (vx_acosf(x2) - x2 * sqrtf(1.0f - x2 * x2));
    float small = VX_PI * rmin * rmin;
    return a < small ? a : small;
}

/* Everything vmesh_opacity_along needs that depends on the direction alone, not on the record: the
 * window, the disk radii, the 27 sub-cell centres projected onto the window and the normaliser (the
 * full voxel's value, see the top of this file). */
typedef struct {
    float half_side, cell, inv_cell_disk, near2, far2, den;
    /* One entry past the 27 sub-cells, far outside the window: the SSE paths read the centres four
     * at a time, and the pad is never the nearest. */
    float pu[VMESH_SUBCELLS + 1], pv[VMESH_SUBCELLS + 1];
#ifndef __OPENCL_VERSION__
    /* The C build's views kept across calls (vmesh_view_of) also remember each window cell's ratio
     * with each sub-cell (vmesh_cell_ratio), NaN until first needed: `ratios` is 0 until the view is
     * asked for a second time (a light's view, asked by every voxel its shadow rays cross), so that a
     * view used once (a voxel's own direction toward the camera) does not pay for filling it. */
    int ratios;
    float ratio[VMESH_SUBCELLS][16]; /* [sub-cell][cy * 4 + cx]: a row of four cells together (vmesh_opacity_sse.h) */
#endif
} vmesh_view;

#define VMESH_RS 0.28867513f /* sphere around a sub-cell of edge 1/3: sqrt(3)/6 */

/* The centre of window cell c (0 .. 3) along either of the window's axes: the one expression for the
 * scalar code and the SSE code, which must agree bit for bit. */
VX_INLINE float vmesh_cell_centre(const vmesh_view *w, int c) { return -w->half_side + ((float)c + 0.5f) * w->cell; }

/* The C build's SSE paths (vmesh_opacity_sse.h): the same bits as the scalar code below, which is
 * the definition and the OpenCL build's code (tests/unit_vmesh_view.c compares the two). */
#ifdef VX_SSE
#include "vmesh_opacity_sse.h"
#endif

/* The 27 sub-cell centres projected onto the window's axes t and b (pu, pv[0..26]). */
VX_INLINE void vmesh_project_scalar(vec3 t, vec3 b, float *pu, float *pv)
{
    for (int i = 0; i < VMESH_SUB; i++)
        for (int j = 0; j < VMESH_SUB; j++)
            for (int k = 0; k < VMESH_SUB; k++) {
                vec3 c = v3(((float)i - 1.0f) / 3.0f, ((float)j - 1.0f) / 3.0f, ((float)k - 1.0f) / 3.0f);
                int s = (i * VMESH_SUB + j) * VMESH_SUB + k;
                pu[s] = v3_dot(c, t);
                pv[s] = v3_dot(c, b);
            }
}

/* The full voxel's value (w's window and projected centres set): the ratio falls with distance, so
 * the nearest of all 27. The projected centres and the window are symmetric about the voxel's
 * centre, so cell (3 - cx, 3 - cy) has the same value: computed for the first 8 cells, counted
 * twice. */
VX_INLINE float vmesh_normaliser_scalar(const vmesh_view *w)
{
    float den = 0.0f, rc = 0.5f * w->cell;
    for (int cy = 0; cy < 2; cy++)
        for (int cx = 0; cx < 4; cx++) {
            float u = vmesh_cell_centre(w, cx), v = vmesh_cell_centre(w, cy);
            float dmin2 = 1e30f;
            for (int s = 0; s < VMESH_SUBCELLS; s++) {
                float du = w->pu[s] - u, dv = w->pv[s] - v, d2 = du * du + dv * dv;
                dmin2 = d2 < dmin2 ? d2 : dmin2;
            }
            den += 2.0f * (dmin2 <= w->near2 ? 1.0f : vmesh_disk_overlap(VMESH_RS, rc, sqrtf(dmin2)) * w->inv_cell_disk);
        }
    return den;
}

VX_INLINE void vmesh_view_setup(vec3 dir, vmesh_view *w)
{
    /* d and -d give mirrored windows; taking the one with d.z >= 0 makes them the same window. */
    vec3 d = v3_normalize_or(dir, v3(0.0f, 0.0f, 1.0f));
    if (d.z < 0.0f)
        d = v3_scale(d, -1.0f);
    vec3 t, b;
    v3_basis(d, &t, &b);
    /* In voxel units (edge 1, centred on the origin): the projection of the cube spans
     * +-(|t.x| + |t.y| + |t.z|) / 2 along t, likewise along b. */
    float half_side = 0.5f * vx_fmaxf(fabsf(t.x) + fabsf(t.y) + fabsf(t.z), fabsf(b.x) + fabsf(b.y) + fabsf(b.z));
    float cell = 0.5f * half_side;  /* 2 half_side / 4 */
    float rc = 0.5f * cell;         /* disk inscribed in a window cell */
    const float rs = VMESH_RS;
    float inv_cell_disk = 1.0f / (VX_PI * rc * rc);
    /* rc < rs for every direction (rc <= sqrt(3)/8): inside near2 a sub-disk contains the cell disk
     * (ratio 1, no trigonometry), beyond far2 they do not meet. */
    float near2 = (rs - rc) * (rs - rc), far2 = (rs + rc) * (rs + rc);
    w->half_side = half_side;
    w->cell = cell;
    w->inv_cell_disk = inv_cell_disk;
    w->near2 = near2;
    w->far2 = far2;
#ifdef VX_SSE
    vmesh_project_sse(t, b, w->pu, w->pv);
#else
    vmesh_project_scalar(t, b, w->pu, w->pv);
#endif
    w->pu[VMESH_SUBCELLS] = w->pv[VMESH_SUBCELLS] = 1e15f;
#ifdef VX_SSE
    float den = vmesh_normaliser_sse(w);
#else
    float den = vmesh_normaliser_scalar(w);
#endif
    w->den = den;
#ifndef __OPENCL_VERSION__
    w->ratios = 0;
#endif
}

/* The overlap ratio of window cell (cx, cy) with sub-cell s's disk, 0 where they do not meet: a
 * function of the view alone (the one expression, whether computed in the loop or remembered). */
VX_INLINE float vmesh_cell_ratio(const vmesh_view *w, int cx, int cy, int s)
{
    float u = vmesh_cell_centre(w, cx), v = vmesh_cell_centre(w, cy);
    float du = w->pu[s] - u, dv = w->pv[s] - v, d2 = du * du + dv * dv;
    if (d2 >= w->far2)
        return 0.0f;
    return d2 <= w->near2 ? 1.0f : vmesh_disk_overlap(VMESH_RS, 0.5f * w->cell, sqrtf(d2)) * w->inv_cell_disk;
}

#ifndef __OPENCL_VERSION__
/* The view of `dir`, computed again only when this thread's table does not hold the view of dir's
 * bits: direct-mapped, VMESH_VIEW_SLOTS views a thread, each slot the last direction that hashed to
 * it. Why: a shadow ray toward a directional light asks every voxel it crosses along one direction,
 * and the tracer asks the voxels' answers toward the camera along one direction per view tile
 * (vx_voxel_eval.view_tile_pixels: vmesh.c asks for 4 x 4 pixels), so most calls find their view
 * and skip this direction-only half of the work (and, from its second use, the ratios: `ratios`).
 * A band of 8 rows meets about 200 tiles; 128 slots of about 2 kB measured 3 % faster than 64 (city
 * 256^3: 123-124 ms against 127-128; bunny 68-69 against 70-71) and within noise of 512. The view
 * is a pure function of dir's bits, so a kept one is the same numbers: the image does not depend on
 * which slots hit. Thread-local: the render threads call this concurrently. (OpenCL C has no such
 * storage: a work-item computes the view per call.) */
#define VMESH_VIEW_SLOTS 128
typedef union {
    vec3 v;
    unsigned int u[3];
} vmesh_view_key;

VX_INLINE vmesh_view *vmesh_view_of(vec3 dir, vmesh_view *scratch)
{
    static _Thread_local vmesh_view slot[VMESH_VIEW_SLOTS];
    static _Thread_local vmesh_view_key key[VMESH_VIEW_SLOTS];
    static _Thread_local unsigned char valid[VMESH_VIEW_SLOTS];
    vmesh_view_key k;
    (void)scratch;
    k.v = dir;
    unsigned h = k.u[0] * 0x9E3779B1u ^ k.u[1] * 0x85EBCA77u ^ k.u[2] * 0xC2B2AE3Du;
    unsigned i = (h >> 16) % VMESH_VIEW_SLOTS;
    vmesh_view *w = &slot[i];
    if (valid[i] && k.u[0] == key[i].u[0] && k.u[1] == key[i].u[1] && k.u[2] == key[i].u[2]) {
        if (!w->ratios) { /* asked again: worth remembering its ratios */
            for (int s = 0; s < VMESH_SUBCELLS; s++)
                for (int c = 0; c < 16; c++)
                    w->ratio[s][c] = NAN;
            w->ratios = 1;
        }
        return w;
    }
    vmesh_view_setup(dir, w);
    key[i] = k;
    valid[i] = 1;
    return w;
}

/* vmesh_cell_ratio, remembered in the view when it keeps its ratios. */
VX_INLINE float vmesh_view_ratio(vmesh_view *w, int cx, int cy, int s)
{
    if (!w->ratios)
        return vmesh_cell_ratio(w, cx, cy, s);
    float *r = &w->ratio[s][cy * 4 + cx];
    if (*r != *r)
        *r = vmesh_cell_ratio(w, cx, cy, s);
    return *r;
}
#else
VX_INLINE vmesh_view *vmesh_view_of(vec3 dir, vmesh_view *scratch)
{
    vmesh_view_setup(dir, scratch);
    return scratch;
}

VX_INLINE float vmesh_view_ratio(vmesh_view *w, int cx, int cy, int s) { return vmesh_cell_ratio(w, cx, cy, s); }
#endif

/* The numerator of the average of the 16 window cells: per cell, the largest opacity x ratio over
 * the record's sub-cells `order` (those holding opacity, most opaque first), summed row by row. A
 * cell stops looking once the next sub-cell cannot beat its best, as ratios are at most 1. This is
 * the definition (the OpenCL build's loop); the C build runs vmesh_cells_sse, the same bits. */
VX_INLINE float vmesh_cells_scalar(VX_GLOBAL const vmesh_record *r, const int *order, int count, vmesh_view *w)
{
    float num = 0.0f;
    for (int cy = 0; cy < 4; cy++)
        for (int cx = 0; cx < 4; cx++) {
            float best = 0.0f;
            for (int o = 0; o < count; o++) {
                int s = order[o];
                float a = vmesh_decode_unorm(r->opacity[s]);
                if (a <= best)
                    break;
                float ratio = vmesh_view_ratio(w, cx, cy, s);
                best = a * ratio > best ? a * ratio : best;
            }
            num += best;
        }
    return num;
}

/* The sub-cells of r holding opacity into order[], most opaque first, ties in index order
 * (insertion sort of at most 27); returns how many. The definition and the OpenCL build's code; the
 * C build ranks them with SSE (vmesh_sorted_subcells_sse), the same order. */
VX_INLINE int vmesh_sorted_subcells(VX_GLOBAL const vmesh_record *r, int *order)
{
    int count = 0;
    for (int s = 0; s < VMESH_SUBCELLS; s++) {
        if (!r->opacity[s])
            continue;
        int j = count++;
        for (; j > 0 && r->opacity[order[j - 1]] < r->opacity[s]; j--)
            order[j] = order[j - 1];
        order[j] = s;
    }
    return count;
}

/* Directional opacity of a record seen along `dir` (either sign: a projection does not depend on
 * it). */
VX_INLINE float vmesh_opacity_along(VX_GLOBAL const vmesh_record *r, vec3 dir)
{
    int order[VMESH_SUBCELLS];
#ifdef VX_SSE
    int count = vmesh_sorted_subcells_sse(r, order);
#else
    int count = vmesh_sorted_subcells(r, order);
#endif
    if (!count)
        return 0.0f;
    vmesh_view scratch;
    vmesh_view *w = vmesh_view_of(dir, &scratch);
#ifdef VX_SSE
    float num = vmesh_cells_sse(r, order, count, w);
#else
    float num = vmesh_cells_scalar(r, order, count, w);
#endif
    float den = w->den;
    return den > 0.0f ? vx_fminf(num / den, 1.0f) : 0.0f;
}

#endif
