#include "opencl_runtime.h"

#include "opencl_pick.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>

#ifdef __SANITIZE_ADDRESS__
/* Under `make test-asan`: PoCL and the LLVM it embeds keep compiler and device state until the
 * process ends and never free it, which LeakSanitizer would report as leaks of every OpenCL render.
 * Only allocations made from inside those libraries are exempted; ours are still checked. */
const char *__lsan_default_suppressions(void);
const char *__lsan_default_suppressions(void)
{
    return "leak:libpocl.so\nleak:libLLVM\nleak:libclang-cpp\nleak:libOpenCL.so\n";
}
#endif

const char *opencl_error_name(cl_int code)
{
    switch (code) {
#define NAME(c) \
    case c:     \
        return #c;
        NAME(CL_DEVICE_NOT_FOUND)
        NAME(CL_DEVICE_NOT_AVAILABLE)
        NAME(CL_COMPILER_NOT_AVAILABLE)
        NAME(CL_MEM_OBJECT_ALLOCATION_FAILURE)
        NAME(CL_OUT_OF_RESOURCES)
        NAME(CL_OUT_OF_HOST_MEMORY)
        NAME(CL_BUILD_PROGRAM_FAILURE)
        NAME(CL_INVALID_VALUE)
        NAME(CL_INVALID_PLATFORM)
        NAME(CL_INVALID_DEVICE)
        NAME(CL_INVALID_CONTEXT)
        NAME(CL_INVALID_COMMAND_QUEUE)
        NAME(CL_INVALID_MEM_OBJECT)
        NAME(CL_INVALID_BUFFER_SIZE)
        NAME(CL_INVALID_BUILD_OPTIONS)
        NAME(CL_INVALID_PROGRAM)
        NAME(CL_INVALID_PROGRAM_EXECUTABLE)
        NAME(CL_INVALID_KERNEL_NAME)
        NAME(CL_INVALID_KERNEL)
        NAME(CL_INVALID_ARG_INDEX)
        NAME(CL_INVALID_ARG_VALUE)
        NAME(CL_INVALID_ARG_SIZE)
        NAME(CL_INVALID_KERNEL_ARGS)
        NAME(CL_INVALID_WORK_DIMENSION)
        NAME(CL_INVALID_WORK_GROUP_SIZE)
        NAME(CL_INVALID_WORK_ITEM_SIZE)
        NAME(CL_INVALID_GLOBAL_WORK_SIZE)
#undef NAME
    case -1001:
        return "CL_PLATFORM_NOT_FOUND_KHR";
    default: {
        static _Thread_local char buf[32];
        snprintf(buf, sizeof buf, "OpenCL error %d", (int)code);
        return buf;
    }
    }
}

/* mkdir -p for the kernel cache (PoCL creates its own subdirectories, not the top one's parents). */
static void make_dirs(const char *path)
{
    char p[4096];
    snprintf(p, sizeof p, "%s", path);
    for (char *s = p + 1; *s; s++)
        if (*s == '/') {
            *s = 0;
            mkdir(p, 0777);
            *s = '/';
        }
    mkdir(p, 0777);
}

static int has_fp64(cl_device_id d)
{
    size_t n = 0;
    if (clGetDeviceInfo(d, CL_DEVICE_EXTENSIONS, 0, NULL, &n) != CL_SUCCESS || n == 0)
        return 0;
    char *ext = malloc(n + 1);
    if (!ext)
        return 0;
    int ok = clGetDeviceInfo(d, CL_DEVICE_EXTENSIONS, n, ext, NULL) == CL_SUCCESS;
    ext[ok ? n : 0] = 0;
    ok = ok && strstr(ext, "cl_khr_fp64") != NULL;
    free(ext);
    return ok;
}

int opencl_open(opencl_runtime *rt, const char *pocl_cache_dir, vx_err *e)
{
    memset(rt, 0, sizeof *rt);
    if (pocl_cache_dir && !getenv("POCL_CACHE_DIR")) {
        make_dirs(pocl_cache_dir);
        setenv("POCL_CACHE_DIR", pocl_cache_dir, 0);
    }
    cl_platform_id platforms[16];
    cl_uint np = 0;
    cl_int err = clGetPlatformIDs(16, platforms, &np);
    if (err != CL_SUCCESS || np == 0)
        return vx_fail(e, "no OpenCL platform found (clGetPlatformIDs: %s); install an OpenCL driver (on Debian: "
                          "pocl-opencl-icd for the CPU) or use --backend c",
                       err != CL_SUCCESS ? opencl_error_name(err) : "0 platforms");
    if (np > 16)
        np = 16;
    /* Every device of every platform, described for opencl_pick_device. */
    enum { MAX_DEVICES = 64 };
    cl_device_id ids[MAX_DEVICES];
    cl_platform_id owner[MAX_DEVICES];
    opencl_device_desc *desc = calloc(MAX_DEVICES, sizeof *desc);
    if (!desc)
        return vx_fail(e, "out of memory listing the OpenCL devices");
    int n = 0;
    for (cl_uint p = 0; p < np && n < MAX_DEVICES; p++) {
        cl_device_id devices[16];
        cl_uint nd = 0;
        if (clGetDeviceIDs(platforms[p], CL_DEVICE_TYPE_ALL, 16, devices, &nd) != CL_SUCCESS)
            continue;
        for (cl_uint d = 0; d < nd && d < 16 && n < MAX_DEVICES; d++, n++) {
            cl_device_type type = CL_DEVICE_TYPE_CPU;
            clGetDeviceInfo(devices[d], CL_DEVICE_TYPE, sizeof type, &type, NULL);
            clGetDeviceInfo(devices[d], CL_DEVICE_NAME, sizeof desc[n].name, desc[n].name, NULL);
            desc[n].name[sizeof desc[n].name - 1] = 0;
            desc[n].cpu = (type & CL_DEVICE_TYPE_CPU) != 0;
            desc[n].fp64 = has_fp64(devices[d]);
            ids[n] = devices[d];
            owner[n] = platforms[p];
        }
    }
    const char *want = getenv("VOXLAB_OPENCL_DEVICE");
    int pick = opencl_pick_device(desc, n, want);
    if (pick < 0) {
        /* Name every device in the message, so that the user sees what there is to pick from. */
        char listed[1024] = "";
        for (int i = 0; i < n; i++) {
            size_t used = strlen(listed);
            snprintf(listed + used, sizeof listed - used, "%s%s (%s%s)", i ? ", " : "", desc[i].name,
                     desc[i].cpu ? "CPU" : "GPU", desc[i].fp64 ? "" : ", no cl_khr_fp64");
        }
        free(desc);
        if (!n)
            return vx_fail(e, "the OpenCL platform has no device; use --backend c");
        if (want && *want)
            return vx_fail(e, "no OpenCL device with double precision (cl_khr_fp64) matches VOXLAB_OPENCL_DEVICE=%s "
                              "(a name's part, gpu or cpu); the devices: %s",
                           want, listed);
        return vx_fail(e, "no OpenCL device with double precision (cl_khr_fp64), which the grid traversal needs "
                          "(the devices: %s); use --backend c",
                       listed);
    }
    rt->device = ids[pick];
    rt->wide = !desc[pick].cpu;
    free(desc);
    clGetPlatformInfo(owner[pick], CL_PLATFORM_NAME, sizeof rt->platform_name, rt->platform_name, NULL);
    clGetDeviceInfo(rt->device, CL_DEVICE_NAME, sizeof rt->device_name, rt->device_name, NULL);
    clGetDeviceInfo(rt->device, CL_DEVICE_MAX_COMPUTE_UNITS, sizeof rt->compute_units, &rt->compute_units, NULL);
    const char *wide = getenv("VOXLAB_OPENCL_WIDE");
    if (wide && (!strcmp(wide, "0") || !strcmp(wide, "1")))
        rt->wide = wide[0] == '1';
    cl_device_fp_config fp = 0;
    clGetDeviceInfo(rt->device, CL_DEVICE_SINGLE_FP_CONFIG, sizeof fp, &fp, NULL);
    rt->correctly_rounded_sqrt = (fp & CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT) != 0;
    rt->context = clCreateContext(NULL, 1, &rt->device, NULL, NULL, &err);
    if (!rt->context)
        return vx_fail(e, "OpenCL: cannot create a context on %s: %s", rt->device_name, opencl_error_name(err));
    rt->queue = clCreateCommandQueue(rt->context, rt->device, 0, &err);
    if (!rt->queue) {
        opencl_close(rt);
        return vx_fail(e, "OpenCL: cannot create a command queue on %s: %s", rt->device_name, opencl_error_name(err));
    }
    return 0;
}

void opencl_close(opencl_runtime *rt)
{
    if (rt->queue)
        clReleaseCommandQueue(rt->queue);
    if (rt->context)
        clReleaseContext(rt->context);
    memset(rt, 0, sizeof *rt);
}

static char *build_log(const opencl_runtime *rt, cl_program prog)
{
    size_t n = 0;
    if (clGetProgramBuildInfo(prog, rt->device, CL_PROGRAM_BUILD_LOG, 0, NULL, &n) != CL_SUCCESS)
        n = 0;
    char *log = malloc(n + 1);
    if (!log)
        return NULL;
    if (n == 0 || clGetProgramBuildInfo(prog, rt->device, CL_PROGRAM_BUILD_LOG, n, log, NULL) != CL_SUCCESS)
        n = 0;
    log[n] = 0;
    while (n > 0 && (log[n - 1] == '\n' || log[n - 1] == ' ' || log[n - 1] == 0))
        log[--n] = 0;
    return log;
}

int opencl_build(const opencl_runtime *rt, const char *source, const char *what, const char *log_path,
                 cl_program *out, vx_err *e)
{
    cl_int err;
    *out = NULL;
    cl_program prog = clCreateProgramWithSource(rt->context, 1, &source, NULL, &err);
    if (!prog)
        return vx_fail(e, "OpenCL: cannot create the program for %s: %s", what, opencl_error_name(err));
    /* Correctly rounded division and sqrt where the device offers them (GPUs default to faster,
     * less exact ones): the C backend's are IEEE. */
    const char *options = rt->correctly_rounded_sqrt ? "-cl-std=CL1.2 -cl-fp32-correctly-rounded-divide-sqrt"
                                                     : "-cl-std=CL1.2";
    err = clBuildProgram(prog, 1, &rt->device, options, NULL, NULL);
    if (err == CL_SUCCESS) {
        *out = prog;
        return 0;
    }
    char *log = build_log(rt, prog);
    clReleaseProgram(prog);
    const char *text = log && *log ? log : "(the compiler left no build log)";
    size_t len = strlen(text), room = 640;
    int wrote = 0;
    if (len > room && log_path) {
        FILE *f = fopen(log_path, "w");
        if (f) {
            wrote = fputs(text, f) >= 0;
            wrote &= fclose(f) == 0;
        }
    }
    if (len > room)
        vx_fail(e, "OpenCL: the kernel for %s failed to build on %s (%s); build log%s%s:\n%.*s\n[...]", what,
                rt->device_name, opencl_error_name(err), wrote ? " in " : " (head)", wrote ? log_path : "",
                (int)room, text);
    else
        vx_fail(e, "OpenCL: the kernel for %s failed to build on %s (%s); build log:\n%s", what, rt->device_name,
                opencl_error_name(err), text);
    free(log);
    return -1;
}

int opencl_check(cl_int err, const char *what, vx_err *e)
{
    if (err == CL_SUCCESS)
        return 0;
    return vx_fail(e, "OpenCL: %s failed: %s", what, opencl_error_name(err));
}

cl_mem opencl_buffer(const opencl_runtime *rt, cl_mem_flags flags, size_t bytes, const void *host, vx_err *e)
{
    if (!host || !bytes)
        flags &= ~(cl_mem_flags)CL_MEM_USE_HOST_PTR;
    else if (!(flags & CL_MEM_USE_HOST_PTR))
        flags |= CL_MEM_COPY_HOST_PTR;
    if (!bytes) {
        host = NULL;
        bytes = 16;
    }
    cl_int err;
    cl_mem b = clCreateBuffer(rt->context, flags, bytes, (void *)host, &err);
    if (!b)
        vx_fail(e, "OpenCL: cannot allocate a %zu-byte buffer on %s: %s", bytes, rt->device_name,
                opencl_error_name(err));
    return b;
}
