#version 460
// Path-tracing pass: one invocation renders samples [sample_start, sample_start +
// sample_count) of one pixel and adds (sum L, count) to accum (docs/path-spec.md sections 7
// and 9), and counts the rays it traced in counters[0].
//
// Pixel order (docs/path-spec.md section 9): invocation slot i = pixel_offset + global id
// covers lane i % 64 of tile i / 64; tiles are 8x8 pixel blocks, shuffled as
// tile' = (tile * pixel_stride) % ntiles with ntiles = pixel_total / 64 (pixel_total is the
// tile-padded slot count) and the stride coprime with ntiles, so that the 64 invocations of a
// workgroup trace neighbouring pixels (coherent) while consecutive workgroups land all over
// the image (balanced). Slots of the padding past the image edge return.
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
  uint i = pc.pixel_offset + gl_GlobalInvocationID.x;
  uint tile = i / 64u;
  uint lane = i % 64u;
  uint ntiles = pc.pixel_total / 64u;
  // The host guarantees (ntiles - 1) * pixel_stride < 2^32: the 32-bit product cannot wrap.
  uint shuffled = (tile * pc.pixel_stride) % ntiles;
  uint width = globals.image.x;
  uint height = globals.image.y;
  uint tiles_x = (width + 7u) / 8u;
  uint px = (shuffled % tiles_x) * 8u + lane % 8u;
  uint py = (shuffled / tiles_x) * 8u + lane / 8u;
  if (px >= width || py >= height) return;
  vec4 sum = vec4(0.0);
  uint rays = 0u, nonfinite = 0u;
  for (uint s = pc.sample_start; s < pc.sample_start + pc.sample_count; ++s) {
    vec3 L = path_radiance(px, py, s, rays);
    // A NaN or infinity would poison the pixel: it is dropped, and counted so that tests
    // and --stats see it (docs/path-spec.md section 9).
    if (any(isnan(L)) || any(isinf(L))) {
      L = vec3(0.0);
      nonfinite++;
    }
    sum += vec4(L, 1.0);
  }
  accum[py * width + px] += sum;
  atomicAdd(counters[0], rays);
  if (nonfinite != 0u) atomicAdd(counters[1], nonfinite);
}
