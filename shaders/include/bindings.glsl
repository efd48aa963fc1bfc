// The pipeline interface shared by render.comp and tests/probe.comp: the scene tables of
// descriptor set 0 (layouts and binding indices from shared/layout.h) and the feature
// specialization constant.
#ifndef BASALT_BINDINGS_GLSL
#define BASALT_BINDINGS_GLSL

#include "shared/layout.h"

// Feature bits of the scene (FEATURE_*): the host specialises the render pipeline so that
// code for absent features is constant-folded away. Every optional part of the shaders is
// gated by (FEATURES & FEATURE_X) != 0u; all bits set (the default, used by the probe) must
// render every scene correctly.
layout(constant_id = 0) const uint FEATURES = 0xffffffffu;

layout(std430, set = 0, binding = BINDING_GLOBALS) restrict readonly buffer GlobalsBuffer {
  Globals globals;
};
layout(std430, set = 0, binding = BINDING_BVH_NODES) restrict readonly buffer BvhNodeBuffer {
  BvhNode bvh_nodes[];
};
layout(std430, set = 0, binding = BINDING_PRIM_REFS) restrict readonly buffer PrimRefBuffer {
  uint prim_refs[];
};
layout(std430, set = 0, binding = BINDING_TRIANGLES) restrict readonly buffer TriangleBuffer {
  Triangle triangles[];
};
layout(std430, set = 0, binding = BINDING_VERTICES) restrict readonly buffer VertexBuffer {
  Vertex vertices[];
};
layout(std430, set = 0, binding = BINDING_MESHES) restrict readonly buffer MeshBuffer {
  Mesh meshes[];
};
layout(std430, set = 0, binding = BINDING_SPHERES) restrict readonly buffer SphereBuffer {
  Sphere spheres[];
};
layout(std430, set = 0, binding = BINDING_MATERIALS) restrict readonly buffer MaterialBuffer {
  Material materials[];
};
layout(std430, set = 0, binding = BINDING_LIGHTS) restrict readonly buffer LightBuffer {
  Light lights[];
};
layout(std430, set = 0, binding = BINDING_LIGHT_CDF) restrict readonly buffer LightCdfBuffer {
  float light_cdf[];
};
layout(std430, set = 0, binding = BINDING_FILTER_CDF) restrict readonly buffer FilterCdfBuffer {
  float filter_cdf[];
};
layout(std430, set = 0, binding = BINDING_ACCUM) restrict buffer AccumBuffer {
  vec4 accum[];  // per pixel: running sum of (L, weight)
};
layout(std430, set = 0, binding = BINDING_COUNTERS) restrict buffer CounterBuffer {
  uint counters[];  // [0]: rays traced in this pass (one atomicAdd per invocation)
};

layout(std430, set = 0, binding = BINDING_MEASURED) restrict readonly buffer MeasuredBuffer {
  float measured[];  // MERL half-angle tables, rgb interleaved (MATERIAL_MEASURED aux0)
};

#endif
