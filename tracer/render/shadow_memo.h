/* The directional lights' opacity memo that both backends keep (render_voxel.c's memo_opacity, the
 * OpenCL kernel's cl_memo_opacity in cl/render.cl): a voxel's opacity toward a directional light,
 * asked of the model once and then read back by every shadow ray that crosses the voxel. Portable
 * (the OpenCL program includes it too). Which renders keep one: render_shadow_memo_lights
 * (render.h). */
#ifndef VX_SHADOW_MEMO_H
#define VX_SHADOW_MEMO_H

/* An empty slot: a NaN's bits, so an opacity that had these bits would simply be computed again. */
#define SHADOW_MEMO_EMPTY 0xFFFFFFFFu

#endif
