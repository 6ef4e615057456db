/* Whether the C build's SSE paths are compiled: SSE4.1 (the project's x86-64-v2 target), never in
 * OpenCL C, and not when VX_NO_SSE is defined. Every such path has a scalar twin, the definition and
 * the OpenCL build's code, with the same bits; the unit tests compare the two (tests/unit_vmesh_view.c,
 * tests/unit_vicini.c). One switch for all of them, so that a build has the SSE paths or has none. */
#ifndef VX_SIMD_H
#define VX_SIMD_H

#if defined(__SSE4_1__) && !defined(__OPENCL_VERSION__) && !defined(VX_NO_SSE)
#define VX_SSE 1
#endif

#endif
