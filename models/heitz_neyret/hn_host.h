/* Host-side pieces of the Heitz–Neyret model that tests and benchmarks reach into (not portable C:
 * the bake side and the start-up tables). */
#ifndef VX_HN_HOST_H
#define VX_HN_HOST_H

#include "hn_cone.h"

struct voxel_grid;

/* The 128 Poisson-disk sample positions of the coverage masks (x, y pairs in the unit disk) and the
 * 256 x 256 mask table built from them (HN_TABLE_WORDS words), built once, on first use, from the
 * shipped positions (hn_mask_points): the same numbers on every run and every thread. */
const float *hn_mask_samples(void);
const unsigned int *hn_mask_table(void);
/* The positions, in double (hn_mask_points.c), and the algorithm that made them (heitz_neyret.c:
 * Mitchell's best candidate from a fixed seed, then Lloyd relaxation; ~30 ms). */
extern const double hn_mask_points[HN_MASK_SAMPLES][2];
void hn_mask_points_generate(double points[HN_MASK_SAMPLES][2]);

/* E[(n.N)^2] over the area of a Gaussian-slope surface with per-axis slope variance sigma2, and
 * its inverse (how the bake turns normals' second moments into a slope variance). */
double hn_m_of_sigma2(double sigma2);
double hn_sigma2_of_m(double m);

/* vx_model.validate_record for heitz-neyret records (heitz_neyret_validate.c). */
int hn_validate_record(const void *record, const vx_record_context *c, char *why, size_t why_size);

#endif
