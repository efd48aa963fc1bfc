#version 460
// The trace stage: the closest hit (or, with pc.pad0 = 1, any hit) of each TraceRay against the
// scene's BVH, with the renderer's own traversal (include/intersect.glsl), specialised for the
// scene's features like the render pipeline. One invocation per ray; pc.pixel_count rays.
// Used by the traversal benchmark (tests/bench/rays.cpp) and GpuRenderer::trace.
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require

#include "include/bindings.glsl"
#include "include/intersect.glsl"

layout(local_size_x = 64) in;

layout(push_constant) uniform Pass {
  PassConstants pc;
};

layout(std430, set = 0, binding = BINDING_PROBE_IN) restrict readonly buffer TraceInBuffer {
  TraceRay trace_in[];
};
layout(std430, set = 0, binding = BINDING_PROBE_OUT) restrict writeonly buffer TraceOutBuffer {
  TraceHit trace_out[];
};

void main() {
  uint i = gl_GlobalInvocationID.x;
  if (i >= pc.pixel_count) return;
  TraceRay r = trace_in[i];
  Hit h = bvh_trace(Ray(r.o_tmax.xyz, r.o_tmax.w, r.d.xyz), pc.pad0 != 0u);
  trace_out[i] = TraceHit(h.prim == INVALID_INDEX ? -1.0 : h.t, h.b1, h.b2, h.prim);
}
