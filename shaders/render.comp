#version 460
// Path-tracing pass: one invocation renders samples [sample_start, sample_start +
// sample_count) of one pixel and adds each sample's (L, 1) to accum in turn
// (docs/path-spec.md sections 7 and 9), and counts the rays it traced in counters[0].
//
// Pixel order (docs/path-spec.md section 9, slot_pixel in camera.glsl): invocation slot
// i = pixel_offset + global id covers lane i % 64 of an 8x8 pixel tile, the tiles shuffled
// with a stride coprime with their count, so that the 64 invocations of a workgroup trace
// neighbouring pixels (coherent) while consecutive workgroups land all over the image
// (balanced). Slots of the padding past the image edge return.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "include/bindings.glsl"
#include "include/integrator.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform Pass {
  PassConstants pc;
};

void main() {
  if (gl_GlobalInvocationID.x >= pc.pixel_count) return;
  uint px, py;
  if (!slot_pixel(pc.pixel_offset + gl_GlobalInvocationID.x, pc.pixel_stride, pc.pixel_total,
                  px, py))
    return;
  uint width = globals.image.x;
  // The pixel's sums go on from what earlier passes left, one sample at a time: the same
  // additions in the same order however the host sizes its passes (it sizes them by the time
  // the last one took), so the image does not depend on the machine's speed.
  vec4 sum = accum[py * width + px];
  uint rays = 0u, nonfinite = 0u;
  // The loop's end is tested at the end of a pass: lavapipe runs a pass that any lane enters
  // in full, and a for loop's closing test cost a whole path (docs/performance.md).
  uint s = pc.sample_start;
  if (pc.sample_count > 0u) while (true) {
    vec3 L = path_radiance(px, py, s, rays);
    // A NaN or infinity would poison the pixel: it is dropped, and counted so that tests
    // and --stats see it (docs/path-spec.md section 9).
    if (any(isnan(L)) || any(isinf(L))) {
      L = vec3(0.0);
      nonfinite++;
    }
    sum += vec4(L, 1.0);
    if (++s >= pc.sample_start + pc.sample_count) break;
  }
  accum[py * width + px] = sum;
  atomicAdd(counters[0], rays);
  if (nonfinite != 0u) atomicAdd(counters[1], nonfinite);
}
