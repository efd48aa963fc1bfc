#version 460
// Path-tracing pass: one invocation renders samples [sample_start, sample_start +
// sample_count) of one pixel of the shuffled pixel order and adds (sum L, count) to accum
// (docs/path-spec.md sections 7 and 9), and counts the rays it traced in counters[0].
#extension GL_GOOGLE_include_directive : require

#include "include/bindings.glsl"
#include "include/integrator.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform Pass {
  PassConstants pc;
};

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= pc.pixel_count) return;
  // Shuffled order: pixel = (index * stride) % total with stride coprime to total. The host
  // guarantees (pixel_total - 1) * pixel_stride < 2^32, so the 32-bit product cannot wrap.
  uint index = (pc.pixel_offset + i) % pc.pixel_total;
  uint pixel = (index * pc.pixel_stride) % pc.pixel_total;
  uint width = globals.image.x;
  uint px = pixel % width;
  uint py = pixel / width;
  vec4 sum = vec4(0.0);
  uint rays = 0u;
  for (uint s = pc.sample_start; s < pc.sample_start + pc.sample_count; ++s)
    sum += vec4(path_radiance(px, py, s, rays), 1.0);
  accum[pixel] += sum;
  atomicAdd(counters[0], rays);
}
