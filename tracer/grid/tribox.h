/* Triangle / axis-aligned box overlap by the separating axis theorem (Akenine-Moller 2001): the
 * 13 candidate axes are the 3 box normals, the triangle normal and the 9 cross products of a
 * triangle edge with a box normal. Every comparison is inclusive, so a triangle that only touches a
 * box (lies on a face, runs along an edge, meets a corner) overlaps it. Zero-area triangles are
 * handled (they reduce to segment or point tests) and never divide by anything.
 *
 * Two forms:
 *  - tribox_overlap: any box, any triangle, one call (reference, setup and test in one).
 *  - tribox_cells: the same test split into a per-triangle setup and a per-cell test against the
 *    unit cells [x,x+1]x[y,y+1]x[z,z+1] of an integer lattice, in the factorisation of Schwarz and
 *    Seidel 2010 (plane test + three 2D edge-function tests, exactly the 13 SAT axes). The voxel
 *    grid builder runs this in its inner loop; it costs a handful of multiply-adds per cell.
 * Both work in double: grid coordinates up to 1024 keep ~40 bits of fraction, so only genuinely
 * borderline cases (distance below ~1e-12 cell) can come out either way. */
#ifndef VX_TRIBOX_H
#define VX_TRIBOX_H

#include "vec.h"

#ifdef __cplusplus
extern "C" {
#endif

/* 1 when the closed box [lo, hi] and the closed triangle (a, b, c) share at least one point. */
int tribox_overlap_d(const double lo[3], const double hi[3], const double a[3], const double b[3],
                     const double c[3]);
int tribox_overlap(vec3 lo, vec3 hi, vec3 a, vec3 b, vec3 c);

/* Per-triangle constants for testing unit lattice cells (coordinates are lattice units). */
typedef struct {
    double n[3];          /* triangle normal (unnormalised, e0 x e1) */
    double plane_lo;      /* the cell at p overlaps the plane iff plane_lo <= n.p <= plane_hi */
    double plane_hi;
    /* edge[a][i] = {A, B, C}: in the projection that drops axis a, with in-plane axes
     * u = (a+1)%3, v = (a+2)%3, the cell at p is not outside edge i iff A*p[u] + B*p[v] + C >= 0. */
    double edge[3][3][3];
    int lo[3], hi[3];     /* cells touched by the triangle's bounding box (not clamped) */
    int dominant;         /* axis of the largest |n| component: cells are enumerated in columns along it */
} tribox_cells;

/* Fills s for triangle (a, b, c) in lattice coordinates. Returns 0 for a zero-area triangle (the
 * normal is exactly zero: s is then unusable and the caller skips it), 1 otherwise. */
int tribox_cells_setup(tribox_cells *s, const double a[3], const double b[3], const double c[3]);

/* The 2D edge test of projection `a` at in-plane cell coordinates (u, v). */
VX_INLINE int tribox_cells_edges(const tribox_cells *s, int a, double u, double v)
{
    const double(*e)[3] = s->edge[a];
    return e[0][0] * u + e[0][1] * v + e[0][2] >= 0.0 && e[1][0] * u + e[1][1] * v + e[1][2] >= 0.0 &&
           e[2][0] * u + e[2][1] * v + e[2][2] >= 0.0;
}

/* Whole SAT for the cell [x,x+1]x[y,y+1]x[z,z+1]; the bounding-box axes are the caller's job
 * (it only asks for cells inside s->lo..s->hi). */
VX_INLINE int tribox_cells_test(const tribox_cells *s, int x, int y, int z)
{
    double p[3] = {(double)x, (double)y, (double)z};
    double np = s->n[0] * p[0] + s->n[1] * p[1] + s->n[2] * p[2];
    return np >= s->plane_lo && np <= s->plane_hi && tribox_cells_edges(s, 0, p[1], p[2]) &&
           tribox_cells_edges(s, 1, p[2], p[0]) && tribox_cells_edges(s, 2, p[0], p[1]);
}

#ifdef __cplusplus
}
#endif

#endif
