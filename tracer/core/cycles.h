/* A cheap clock for splitting a timed region between its parts: the time-stamp counter where there
 * is one (constant-rate on the x86-64 machines we run on), else nanoseconds. Only ratios of two
 * counts are used (the model's share of a render, each model's share of a shared bake), so the
 * unit does not matter. */
#ifndef VX_CYCLES_H
#define VX_CYCLES_H

#include <stdint.h>

#if defined(__x86_64__) || defined(__i386__)
#include <x86intrin.h>
static inline uint64_t cycles(void) { return __rdtsc(); }
#else
#include "parallel.h"
static inline uint64_t cycles(void) { return (uint64_t)(now_seconds() * 1e9); }
#endif

#endif
