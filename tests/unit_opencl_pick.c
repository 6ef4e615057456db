/* tracer/backends/opencl/opencl_pick.c: which OpenCL device the backend opens. The cases a machine
 * shows (PoCL's CPU listed before an NVIDIA GPU, as on the H200 machine where the CPU was first
 * picked), then every list of up to 4 devices of every kind against a reference written as a rule
 * over the candidates' ranks, for each way of asking. */
#include <stdio.h>
#include <string.h>

#include "opencl_pick.h"
#include "unit.h"

static opencl_device_desc dev(const char *name, int cpu, int fp64)
{
    opencl_device_desc d = {.cpu = cpu, .fp64 = fp64};
    snprintf(d.name, sizeof d.name, "%s", name);
    return d;
}

/* The rule, written independently: among the devices with double precision that the request
 * admits, the one with the smallest (rank, index), where rank puts non-CPUs first when no kind or
 * name is asked for. */
static int reference(const opencl_device_desc *d, int n, const char *want)
{
    int best = -1, best_rank = 0;
    for (int i = 0; i < n; i++) {
        if (!d[i].fp64)
            continue;
        int admitted, rank = 0;
        if (!want || !*want) {
            admitted = 1;
            rank = d[i].cpu;
        } else if (!strcmp(want, "cpu") || !strcmp(want, "CPU"))
            admitted = d[i].cpu;
        else if (!strcmp(want, "gpu") || !strcmp(want, "Gpu"))
            admitted = !d[i].cpu;
        else
            admitted = strstr(d[i].name, want) != NULL; /* the names below are lower case, as is want */
        if (admitted && (best < 0 || rank < best_rank)) {
            best = i;
            best_rank = rank;
        }
    }
    return best;
}

int main(void)
{
    opencl_device_desc h200[] = {dev("cpu-skylake-avx512-Intel(R) Xeon(R) Processor", 1, 1), dev("NVIDIA H200", 0, 1)};
    CHECK("a GPU listed after PoCL's CPU is picked", opencl_pick_device(h200, 2, NULL) == 1);
    CHECK("an empty request is no request", opencl_pick_device(h200, 2, "") == 1);
    CHECK("cpu asks for the CPU", opencl_pick_device(h200, 2, "cpu") == 0);
    CHECK("GPU (any case) asks for the GPU", opencl_pick_device(h200, 2, "GPU") == 1);
    CHECK("a part of a name, any case", opencl_pick_device(h200, 2, "h200") == 1);
    CHECK("a part of the CPU's name", opencl_pick_device(h200, 2, "xeon") == 0);
    CHECK("a name nothing has", opencl_pick_device(h200, 2, "radeon") == -1);
    opencl_device_desc single[] = {dev("Intel(R) UHD Graphics", 0, 0), dev("pthread-haswell", 1, 1)};
    CHECK("a GPU without double precision is passed over", opencl_pick_device(single, 2, NULL) == 1);
    CHECK("...also when asked for by name", opencl_pick_device(single, 2, "uhd") == -1);
    CHECK("...and gpu then finds none", opencl_pick_device(single, 2, "gpu") == -1);
    CHECK("no devices", opencl_pick_device(single, 0, NULL) == -1);

    /* Every list of up to 4 devices, each one of 4 kinds (CPU or not, with or without fp64), with
     * names that share parts, for every request. */
    const char *names[4] = {"alpha gpu", "beta cpu", "gamma", "delta alpha"};
    const char *wants[] = {NULL, "", "cpu", "CPU", "gpu", "Gpu", "alpha", "beta", "gamma", "delta", "zeta", "a"};
    int lists = 0, wrong = 0;
    for (int n = 0; n <= 4; n++) {
        int combos = 1;
        for (int i = 0; i < n; i++)
            combos *= 16; /* 4 kinds x 4 names */
        for (int c = 0; c < combos; c++) {
            opencl_device_desc d[4];
            for (int i = 0, k = c; i < n; i++, k /= 16)
                d[i] = dev(names[(k / 4) % 4], k & 1, (k >> 1) & 1);
            for (size_t w = 0; w < sizeof wants / sizeof *wants; w++) {
                lists++;
                int got = opencl_pick_device(d, n, wants[w]), want = reference(d, n, wants[w]);
                if (got != want && wrong++ < 5)
                    printf("# %d devices (case %d), request %s: picked %d, the rule says %d\n", n, c,
                           wants[w] ? wants[w] : "(none)", got, want);
            }
        }
    }
    printf("# %d lists and requests, %d picked otherwise than the rule\n", lists, wrong);
    CHECK("every list of up to 4 devices, every request: the rule's pick", wrong == 0 && lists > 800000);
    return unit_exit();
}
