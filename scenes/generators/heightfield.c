/* "heightfield": Heitz & Neyret's validation case, a finely tessellated Gaussian random height field
 * whose colour follows its height (see heightfield.h for the maths). The bumps are about a voxel
 * across at 128^3 and smaller still at coarser grids, so a voxel model must reproduce masking: at
 * grazing views the visible bumps are the high, light ones, and the pixel colour shifts with the
 * view. */
#include "heightfield.h"

#include <math.h>
#include <stdlib.h>

#include "json_util.h"
#include "rng.h"

static const char *const heightfield_slots[] = {"surface", NULL};

enum { MAX_WAVES = 1024 };

static int read_colors(const cJSON *params, const char *where, heightfield_surface *s, vx_err *e)
{
    s->mean_color = v3(0.5f, 0.5f, 0.5f);
    /* Bumps light and warm (0.85, 0.8, 0.7), valleys dark and cool (0.15, 0.2, 0.3): the shift
     * with viewing angle shows in both brightness and hue. */
    s->delta_color = v3(0.35f, 0.3f, 0.2f);
    if (json_vec3(params, "mean_color", where, &s->mean_color, e) ||
        json_vec3(params, "delta_color", where, &s->delta_color, e))
        return -1;
    for (int c = 0; c < 3; c++) {
        float mean = v3_get(s->mean_color, c), delta = fabsf(v3_get(s->delta_color, c));
        if (mean < 0.0f || mean > 1.0f)
            return vx_fail(e, "%s.mean_color[%d]: %g is out of range (expected 0 to 1)", where, c, mean);
        if (mean - delta < 0.0f || mean + delta > 1.0f)
            return vx_fail(e, "%s.delta_color[%d]: mean_color +- delta_color must stay within 0 to 1 (%g +- %g)",
                           where, c, mean, delta);
    }
    return 0;
}

static int read_params(const cJSON *params, const char *where, heightfield_surface *s, vx_err *e)
{
    static const char *const known[] = {"size",           "resolution", "sigma_h",    "waves",      "wavelength_min",
                                        "wavelength_max", "mean_color", "delta_color", NULL};
    s->size = 4.0;
    s->resolution = 512;
    s->wave_count = 128;
    if (params && !cJSON_IsObject(params))
        return vx_fail(e, "%s: expected an object of parameters", where);
    if (json_only_fields(params, where, known, e) ||
        json_number_in(params, "size", where, 0.01, 1000.0, &s->size, e) ||
        json_int_in(params, "resolution", where, 8, 4096, &s->resolution, e) ||
        json_int_in(params, "waves", where, 1, MAX_WAVES, &s->wave_count, e))
        return -1;
    /* Default band: wavelengths size/96 to size/32, i.e. 1.3 to 4 voxels of a 128^3 grid and 5.3 to
     * 16 quads at resolution 512. As fine as the mesh can follow: a wave needs about 5 quads per
     * period for the piecewise-linear mesh to keep its height statistics (the normals are exact
     * anyway). Coarser meshes get a coarser default band rather than an aliased surface. */
    double quad = s->size / s->resolution;
    s->wavelength_min = fmax(s->size / 96.0, 5.0 * quad);
    if (json_number_in(params, "wavelength_min", where, 3.0 * quad, s->size, &s->wavelength_min, e))
        return -1;
    s->wavelength_max = fmin(3.0 * s->wavelength_min, s->size);
    if (json_number_in(params, "wavelength_max", where, s->wavelength_min, s->size, &s->wavelength_max, e))
        return -1;
    /* Default 0.15 x the shortest wavelength: an rms slope about 0.65 (Beckmann alpha ~ 0.65) at
     * the default band: rough enough for strong masking at grazing angles, not a bed of spikes. */
    s->sigma_h = 0.15 * s->wavelength_min;
    if (json_number_in(params, "sigma_h", where, 1e-9, 0.25 * s->size, &s->sigma_h, e))
        return -1;
    return read_colors(params, where, s, e);
}

/* Draws distinct lattice wave vectors (m, n), frequency |(m, n)| / size uniform in the band and
 * direction uniform. (m, n) and (-m, -n) are the same wave up to phase (they would not be
 * orthogonal), so only one half-plane is used. */
static int draw_waves(heightfield_surface *s, uint64_t seed, const char *where, vx_err *e)
{
    int n_waves = s->wave_count;
    int *lattice = malloc(sizeof(int) * 2 * (size_t)n_waves);
    s->kx = malloc(sizeof(double) * (size_t)n_waves);
    s->kz = malloc(sizeof(double) * (size_t)n_waves);
    s->phase = malloc(sizeof(double) * (size_t)n_waves);
    if (!lattice || !s->kx || !s->kz || !s->phase)
        abort(); /* as mesh.c: a few KiB failing is not an input error */
    rng r = rng_seed(seed, 0);
    double cycles_min = s->size / s->wavelength_max, cycles_max = s->size / s->wavelength_min;
    int found = 0;
    for (long attempt = 0; found < n_waves && attempt < 1000L * n_waves; attempt++) {
        double cycles = cycles_min + (cycles_max - cycles_min) * rng_double(&r);
        double angle = M_PI * rng_double(&r);
        int m = (int)lround(cycles * cos(angle)), n = (int)lround(cycles * sin(angle));
        if (n == 0 && m < 0)
            m = -m;
        double rounded = sqrt((double)m * m + (double)n * n);
        if (rounded < cycles_min || rounded > cycles_max || rounded == 0.0)
            continue;
        int duplicate = 0;
        for (int i = 0; i < found && !duplicate; i++)
            duplicate = lattice[2 * i] == m && lattice[2 * i + 1] == n;
        if (duplicate)
            continue;
        lattice[2 * found] = m;
        lattice[2 * found + 1] = n;
        s->kx[found] = 2.0 * M_PI * m / s->size;
        s->kz[found] = 2.0 * M_PI * n / s->size;
        s->phase[found] = 2.0 * M_PI * rng_double(&r);
        found++;
    }
    free(lattice);
    if (found < n_waves)
        return vx_fail(e,
                       "%s.waves: only %d distinct waves fit the wavelength band %g to %g on a patch of size %g "
                       "(lower waves or widen the band)",
                       where, found, s->wavelength_min, s->wavelength_max, s->size);
    s->amplitude = s->sigma_h * sqrt(2.0 / n_waves);
    return 0;
}

int heightfield_surface_init(heightfield_surface *s, const cJSON *params, const char *where, uint64_t seed,
                             vx_err *e)
{
    s->kx = s->kz = s->phase = NULL;
    if (!where)
        where = "params";
    if (read_params(params, where, s, e) || draw_waves(s, seed, where, e)) {
        heightfield_surface_free(s);
        return -1;
    }
    return 0;
}

void heightfield_surface_free(heightfield_surface *s)
{
    free(s->kx);
    free(s->kz);
    free(s->phase);
    s->kx = s->kz = s->phase = NULL;
}

/* Running sums over waves: cos of the phase (the height) and sin times kx, kz (the gradient).
 * Wave w goes to lane w % LANES: independent chains the CPU (and vectoriser) can overlap, in a
 * fixed order, so results stay bit-reproducible. */
enum { LANES = 4 };
typedef struct {
    double cos_sum[LANES], kx_sin_sum[LANES], kz_sin_sum[LANES];
} wave_sums;

/* Adds waves [first, first + count) (first a multiple of LANES), given e^{i kx x} in ex and
 * e^{i (kz z + phase)} in ez, each as count real parts then count imaginary parts. cos and sin of
 * the full phase come from one complex product, so the mesh can tabulate the x factor per column
 * and the z factor per row instead of calling cos per vertex and wave. The mesh and
 * heightfield_eval both go through here, in the same order: bit-identical. */
static void add_waves(const heightfield_surface *s, int first, int count, const double *ex, const double *ez,
                      wave_sums *sums)
{
    const double *xr = ex, *xi = ex + count, *zr = ez, *zi = ez + count;
    const double *kx = s->kx + first, *kz = s->kz + first;
    double c[LANES], gx[LANES], gz[LANES];
    for (int l = 0; l < LANES; l++) {
        c[l] = sums->cos_sum[l];
        gx[l] = sums->kx_sin_sum[l];
        gz[l] = sums->kz_sin_sum[l];
    }
    int w = 0;
    for (; w + LANES <= count; w += LANES) {
        for (int l = 0; l < LANES; l++) {
            double cos_phase = xr[w + l] * zr[w + l] - xi[w + l] * zi[w + l];
            double sin_phase = xr[w + l] * zi[w + l] + xi[w + l] * zr[w + l];
            c[l] += cos_phase;
            gx[l] += kx[w + l] * sin_phase;
            gz[l] += kz[w + l] * sin_phase;
        }
    }
    for (int l = 0; w < count; w++, l++) {
        double cos_phase = xr[w] * zr[w] - xi[w] * zi[w], sin_phase = xr[w] * zi[w] + xi[w] * zr[w];
        c[l] += cos_phase;
        gx[l] += kx[w] * sin_phase;
        gz[l] += kz[w] * sin_phase;
    }
    for (int l = 0; l < LANES; l++) {
        sums->cos_sum[l] = c[l];
        sums->kx_sin_sum[l] = gx[l];
        sums->kz_sin_sum[l] = gz[l];
    }
}

static void x_factors(const heightfield_surface *s, int first, int count, double x, double *ex)
{
    for (int w = 0; w < count; w++) {
        double a = s->kx[first + w] * x;
        ex[w] = cos(a);
        ex[count + w] = sin(a);
    }
}

static void z_factors(const heightfield_surface *s, int first, int count, double z, double *ez)
{
    for (int w = 0; w < count; w++) {
        double a = s->kz[first + w] * z + s->phase[first + w];
        ez[w] = cos(a);
        ez[count + w] = sin(a);
    }
}

static double lane_total(const double *lanes) { return (lanes[0] + lanes[1]) + (lanes[2] + lanes[3]); }

/* h = A sum cos, dh/dx = -A sum kx sin, dh/dz = -A sum kz sin. */
static double finish(const heightfield_surface *s, const wave_sums *sums, vec3 *normal)
{
    if (normal) {
        double nx = s->amplitude * lane_total(sums->kx_sin_sum), nz = s->amplitude * lane_total(sums->kz_sin_sum);
        double len = sqrt(nx * nx + 1.0 + nz * nz);
        *normal = v3((float)(nx / len), (float)(1.0 / len), (float)(nz / len));
    }
    return s->amplitude * lane_total(sums->cos_sum);
}

double heightfield_color_weight(const heightfield_surface *s, double h) { return erf(h / (M_SQRT2 * s->sigma_h)); }

vec3 heightfield_color(const heightfield_surface *s, double h)
{
    return v3_madd(s->mean_color, s->delta_color, (float)heightfield_color_weight(s, h));
}

double heightfield_eval(const heightfield_surface *s, double x, double z, vec3 *normal, vec3 *color)
{
    enum { CHUNK = 64 }; /* a multiple of LANES */
    double ex[2 * CHUNK], ez[2 * CHUNK];
    wave_sums sums = {{0.0}, {0.0}, {0.0}};
    for (int first = 0; first < s->wave_count; first += CHUNK) {
        int count = s->wave_count - first < CHUNK ? s->wave_count - first : CHUNK;
        x_factors(s, first, count, x, ex);
        z_factors(s, first, count, z, ez);
        add_waves(s, first, count, ex, ez, &sums);
    }
    double h = finish(s, &sums, normal);
    if (color)
        *color = heightfield_color(s, h);
    return h;
}

static int heightfield_generate(const cJSON *params, const char *where, uint64_t seed,
                                const uint32_t *slot_materials, mesh *out, vx_err *e)
{
    heightfield_surface s;
    if (heightfield_surface_init(&s, params, where, seed, e))
        return -1;
    int res = s.resolution, waves = s.wave_count;
    double half = 0.5 * s.size;
    /* x factors for every column, computed once; z factors once per row. */
    double *ex = malloc(sizeof(double) * 2 * (size_t)waves * (size_t)(res + 1));
    double *ez = malloc(sizeof(double) * 2 * (size_t)waves);
    if (!ex || !ez)
        abort();
    /* Coordinates are rounded to float first, so heightfield_eval at a vertex's stored x, z
     * reproduces its height exactly. */
    for (int i = 0; i <= res; i++)
        x_factors(&s, 0, waves, (double)(float)(-half + s.size * i / res), ex + 2 * (size_t)waves * (size_t)i);
    uint32_t first = (uint32_t)out->vertex_count;
    for (int j = 0; j <= res; j++) {
        float z = (float)(-half + s.size * j / res);
        z_factors(&s, 0, waves, (double)z, ez);
        for (int i = 0; i <= res; i++) {
            float x = (float)(-half + s.size * i / res);
            wave_sums sums = {{0.0}, {0.0}, {0.0}};
            add_waves(&s, 0, waves, ex + 2 * (size_t)waves * (size_t)i, ez, &sums);
            vec3 normal;
            double h = finish(&s, &sums, &normal);
            uint32_t v = mesh_add_vertex(out, v3(x, (float)h, z), normal, (float)i / res, (float)j / res);
            mesh_set_vertex_color(out, v, heightfield_color(&s, h));
        }
    }
    uint32_t row = (uint32_t)res + 1;
    for (uint32_t j = 0; j < (uint32_t)res; j++) {
        for (uint32_t i = 0; i < (uint32_t)res; i++) {
            uint32_t a = first + j * row + i; /* (x0, z0) */
            uint32_t b = a + row;             /* (x0, z1) */
            uint32_t c = b + 1, d = a + 1;    /* (x1, z1), (x1, z0) */
            /* (x0,z0), (x0,z1), (x1,z1) is counter-clockwise seen from +y. */
            mesh_add_triangle(out, a, b, c, slot_materials[0]);
            mesh_add_triangle(out, a, c, d, slot_materials[0]);
        }
    }
    free(ex);
    free(ez);
    heightfield_surface_free(&s);
    return 0;
}

const scene_generator generator_heightfield = {
    .name = "heightfield",
    .description = "Gaussian random height field with height-correlated vertex colours, Heitz & Neyret's test "
                   "(params: size, resolution, sigma_h, waves, wavelength_min, wavelength_max, mean_color, "
                   "delta_color)",
    .slots = heightfield_slots,
    .generate = heightfield_generate,
};
