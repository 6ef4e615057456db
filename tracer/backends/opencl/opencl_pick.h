/* Which OpenCL device the backend opens, as a pure function of the devices' descriptions (so that
 * the choice is tested without the devices). A machine with a GPU usually lists a CPU platform
 * too (PoCL's), often first: the GPU is what a researcher who asks for OpenCL there means. */
#ifndef VX_OPENCL_PICK_H
#define VX_OPENCL_PICK_H

typedef struct {
    char name[256];
    int cpu;  /* CL_DEVICE_TYPE_CPU */
    int fp64; /* cl_khr_fp64, which the grid traversal needs */
} opencl_device_desc;

/* The index of the device to open among d[0..n), or -1 when none will do. Only devices with double
 * precision qualify. want NULL or "": the first non-CPU device (a GPU or other accelerator), else
 * the first CPU; "gpu" or "cpu" (any case): the first of that kind; anything else: the first whose
 * name contains `want`, ignoring case (VOXLAB_OPENCL_DEVICE). */
int opencl_pick_device(const opencl_device_desc *d, int n, const char *want);

#endif
