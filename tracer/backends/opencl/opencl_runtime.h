/* The OpenCL runtime for the render backend: picking a device, a context and a queue, and building
 * a program with its build log reported. Every failure (no platform, no device with double
 * precision, a kernel that does not compile) is a message in vx_err, never a crash. */
#ifndef VX_OPENCL_RUNTIME_H
#define VX_OPENCL_RUNTIME_H

#define CL_TARGET_OPENCL_VERSION 120
#include <CL/cl.h>

#include "error.h"

typedef struct {
    cl_device_id device;
    cl_context context;
    cl_command_queue queue;
    char device_name[256];
    char platform_name[256];
    cl_uint compute_units;
    int correctly_rounded_sqrt; /* the device honours -cl-fp32-correctly-rounded-divide-sqrt */
    /* 1: launch wide, as a GPU needs (opencl_host.h): any device that is not a CPU. The
     * environment's VOXLAB_OPENCL_WIDE=1 or 0 forces one launch on any device (so that the GPU's
     * launch is tested on PoCL, and the CPU's measured on a GPU). */
    int wide;
} opencl_runtime;

/* The name of an OpenCL error code ("CL_OUT_OF_RESOURCES"), or "OpenCL error N". */
const char *opencl_error_name(cl_int code);

/* 0 when err is CL_SUCCESS; else -1 with "OpenCL: <what> failed: <error name>" in e. */
int opencl_check(cl_int err, const char *what, vx_err *e);

/* A buffer of `bytes` holding `host` (copied, or used in place with CL_MEM_USE_HOST_PTR in flags:
 * on a CPU device the same memory, no copy and no second set of fresh pages; host NULL: left
 * uninitialised). OpenCL has no empty buffers: an empty one gets 16 bytes that nothing reads.
 * NULL, with the reason in e, when the device cannot allocate it. */
cl_mem opencl_buffer(const opencl_runtime *rt, cl_mem_flags flags, size_t bytes, const void *host, vx_err *e);

/* Opens the device opencl_pick_device chooses (opencl_pick.h: a GPU before a CPU, or the one
 * VOXLAB_OPENCL_DEVICE names), among those with double precision, which the grid traversal needs.
 * pocl_cache_dir: where PoCL keeps compiled kernels unless POCL_CACHE_DIR is
 * already set (it must be set before the first OpenCL call, which loads PoCL). */
int opencl_open(opencl_runtime *rt, const char *pocl_cache_dir, vx_err *e);
void opencl_close(opencl_runtime *rt);

/* Builds `source` for the runtime's device; on failure the message names `what` and carries the
 * build log (its head, when long: the whole log goes to log_path when that is not NULL). */
int opencl_build(const opencl_runtime *rt, const char *source, const char *what, const char *log_path,
                 cl_program *out, vx_err *e);

#endif
