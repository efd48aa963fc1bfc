// Common file shared across C++ host code and GLSL device code: every buffer struct,
// binding index, type tag and flag that crosses the host/device boundary lives here.
// Layout rules: std430, members are vec4/uvec4/mat4 or a vec3 followed by a 4-byte scalar,
// so that GLSL std430 offsets equal C++ offsets; tests/layout_test.cpp asserts every size
// and offset, and the static_asserts below catch drift at compile time.
// This header holds layouts and tags only, never logic (DEVELOPERS.md: share data, not code).
#ifndef BASALT_LAYOUT_H
#define BASALT_LAYOUT_H

#ifdef __cplusplus
#include <cstddef>
#include <cstdint>
#include <glm/glm.hpp>
namespace basalt::gpu {
using uint = std::uint32_t;
using vec3 = glm::vec3;
using vec4 = glm::vec4;
using uvec4 = glm::uvec4;
using mat4 = glm::mat4;
#define BASALT_CONST inline constexpr
#else
#define BASALT_CONST const
#endif

// ---- descriptor bindings (set 0) -------------------------------------------------------
#define BINDING_GLOBALS 0
#define BINDING_BVH_NODES 1
#define BINDING_PRIM_REFS 2
#define BINDING_TRIANGLES 3
#define BINDING_VERTICES 4
#define BINDING_MESHES 5
#define BINDING_SPHERES 6
#define BINDING_MATERIALS 7
#define BINDING_LIGHTS 8
#define BINDING_LIGHT_CDF 9
#define BINDING_FILTER_CDF 10
#define BINDING_ACCUM 11
#define BINDING_COUNTERS 12  // uint counters[]: [0] rays traced, [1] non-finite samples dropped
#define BINDING_COUNT 13

// Probe shaders (tests) add their input and output tables to the same set.
#define BINDING_PROBE_IN 13
#define BINDING_PROBE_OUT 14

// ---- feature bits (specialization constant 0 of the render pipeline) --------------------
// The host derives the scene's feature set; the pipeline is specialised so that code for
// absent features is constant-folded away. Later issues append bits; never renumber.
BASALT_CONST uint FEATURE_TRIANGLES = 1u << 0;
BASALT_CONST uint FEATURE_SPHERES = 1u << 1;
BASALT_CONST uint FEATURE_LIGHT_POINT = 1u << 2;
BASALT_CONST uint FEATURE_LIGHT_SPOT = 1u << 3;
BASALT_CONST uint FEATURE_LIGHT_DISTANT = 1u << 4;
BASALT_CONST uint FEATURE_LIGHT_INFINITE = 1u << 5;
BASALT_CONST uint FEATURE_LIGHT_AREA = 1u << 6;
BASALT_CONST uint FEATURE_MAT_DIFFUSE = 1u << 7;
BASALT_CONST uint FEATURE_FILTER_GAUSSIAN = 1u << 8;
BASALT_CONST uint FEATURE_THIN_LENS = 1u << 9;
BASALT_CONST uint FEATURE_SHADING_NORMALS = 1u << 10;
BASALT_CONST uint FEATURE_COUNT = 11u;

// ---- primitive references ------------------------------------------------------------
// A BVH leaf covers prim_refs[a .. a+b). A ref is a triangle index, or a sphere index
// with PRIM_SPHERE_BIT set.
BASALT_CONST uint PRIM_SPHERE_BIT = 0x80000000u;
BASALT_CONST uint PRIM_INDEX_MASK = 0x7fffffffu;
BASALT_CONST uint INVALID_INDEX = 0xffffffffu;

// ---- material tags ---------------------------------------------------------------------
BASALT_CONST uint MATERIAL_DIFFUSE = 1u;
BASALT_CONST uint MATERIAL_SLOTS = 8u;
// Diffuse: slot 0 = reflectance (rgb).
BASALT_CONST uint SLOT_DIFFUSE_REFLECTANCE = 0u;

// ---- light tags ------------------------------------------------------------------------
BASALT_CONST uint LIGHT_POINT = 1u;
BASALT_CONST uint LIGHT_SPOT = 2u;
BASALT_CONST uint LIGHT_DISTANT = 3u;
BASALT_CONST uint LIGHT_INFINITE_UNIFORM = 4u;
BASALT_CONST uint LIGHT_AREA_TRIANGLE = 5u;
BASALT_CONST uint LIGHT_AREA_SPHERE = 6u;
BASALT_CONST uint LIGHT_FLAG_TWOSIDED = 1u;
BASALT_CONST uint MAX_INFINITE_LIGHTS = 4u;

// ---- shape flags -----------------------------------------------------------------------
// FLIP_NORMAL: flip the geometric normal (pbrt-v4: ReverseOrientation xor the transform
// swapping handedness for triangles; ReverseOrientation alone for spheres). Ignored for
// triangles of a mesh with per-vertex normals, whose geometric normal is face-forwarded to
// the interpolated shading normal instead.
BASALT_CONST uint SHAPE_FLAG_FLIP_NORMAL = 1u << 0;
BASALT_CONST uint SHAPE_FLAG_HAS_NORMALS = 1u << 1;
BASALT_CONST uint SHAPE_FLAG_HAS_UV = 1u << 2;

// ---- filter tags -----------------------------------------------------------------------
BASALT_CONST uint FILTER_BOX = 0u;
BASALT_CONST uint FILTER_GAUSSIAN = 1u;

/// Scene-wide constants: camera, image, integrator and filter settings.
struct Globals {
  mat4 world_from_camera;  // pbrt camera space (left-handed, +z forward) to world
  vec4 screen;             // screen window: xmin, xmax, ymin, ymax
  vec4 lens;               // tan(fov/2), lens radius, focal distance, unused
  vec4 filter_radius;      // filter radius x, y; unused, unused
  vec4 scene_sphere;       // world bounding sphere: centre xyz, radius w
  uvec4 image;             // width, height, max_depth, seed
  uvec4 counts;            // light count, infinite light count, filter type, filter table size N
  uvec4 infinite_lights;   // indices of the first MAX_INFINITE_LIGHTS infinite lights
  uvec4 features;          // x: feature bits of the scene (same as the specialization constant)
};

/// BVH node: interior when b == 0 (children at a and a+1), else leaf over prim_refs[a, a+b).
struct BvhNode {
  vec3 lo;
  uint a;
  vec3 hi;
  uint b;
};

/// Triangle: vertex indices into the vertex table and the mesh it belongs to.
struct Triangle {
  uint v0, v1, v2;
  uint mesh;
};

/// Vertex: world-space position and u; world-space normal (zero if none) and v.
struct Vertex {
  vec4 p_u;
  vec4 n_v;
};

/// Per-mesh data: material, area lights (light of triangle t = light_base + t - tri_base).
struct Mesh {
  uint material;
  uint light_base;  // INVALID_INDEX when the mesh is not emissive
  uint tri_base;    // index of the mesh's first triangle in the triangle table
  uint flags;       // SHAPE_FLAG_*
};

/// Sphere in world space (similarity transforms only); axes keep the object frame for (u,v).
struct Sphere {
  vec4 center_radius;  // world centre xyz, world radius w
  vec4 axis_x;         // object x, y, z axes in world space, unit length
  vec4 axis_y;
  vec4 axis_z;
  uint material;
  uint light;  // INVALID_INDEX when not emissive
  uint flags;  // SHAPE_FLAG_*
  uint pad0;
};

/// Material: a type tag and parameter slots; each slot is a constant or a texture.
struct Material {
  uint type;
  uint flags;
  uint pad0;
  uint pad1;
  vec4 value[8];    // constant value of each slot (MATERIAL_SLOTS)
  uvec4 texture[2]; // texture index of slot i at texture[i / 4][i % 4]; INVALID_INDEX = constant
};

/// Light: type tag, emitted quantity, geometry and its selection probability.
struct Light {
  uint type;
  uint prim;   // area lights: triangle index or sphere index
  uint flags;  // LIGHT_FLAG_*
  float pmf;   // probability that the light sampler picks this light
  vec4 L;      // rgb radiance (area, distant, infinite) or intensity (point, spot), scale applied
  vec4 pos;    // point, spot: world position
  vec4 dir;    // spot: unit axis (direction of emission); distant: unit direction towards light
  vec4 params; // spot: cos(falloff start), cos(falloff end); triangle: world area in x
};

/// Push constants of the render pass: which samples and which pixels this dispatch covers.
struct PassConstants {
  uint sample_start;
  uint sample_count;
  uint pixel_offset;  // first invocation slot of this pass (slots: 8x8 tiles of 64, shuffled)
  uint pixel_count;   // slots in this pass
  uint pixel_stride;  // tile shuffle: tile' = (tile * stride) % (pixel_total / 64), coprime
  uint pixel_total;   // all slots: the tile count times 64
  uint pad0;
  uint pad1;
};

// ---- test probes (shaders/tests/probe.comp and its CPU twin host/cpu/probe.cpp) ---------
BASALT_CONST uint PROBE_CLOSEST = 0u;   // in: ray o, d, tMax  -> out: t, b1, b2 / prim
BASALT_CONST uint PROBE_OCCLUDED = 1u;  // in: ray o, d, tMax  -> out: u.x = 1 if occluded
BASALT_CONST uint PROBE_RESPAWN = 2u;   // in: ray; extra.xyz = continuation direction
                                        // -> out: first hit as CLOSEST, then the hit of the
                                        //    ray spawned from it (offset_ray) in f1 / u.y
BASALT_CONST uint PROBE_RNG = 3u;       // in: key.yzw = px, py, sample; extra.x = dim (as uint
                                        //    bits) -> out: f0.x = rng value
BASALT_CONST uint PROBE_CAMERA = 4u;    // in: key.yzw = px, py, sample -> out: f0 = origin,
                                        //    f1 = direction of the camera ray
BASALT_CONST uint PROBE_CAMERA_DIFF = 5u;  // in: key.yzw = px, py, sample -> out: f0.xyz =
                                           //    rx direction, f1.xyz = ry direction of the
                                           //    camera ray's differentials; f0.w, f1.w unused

/// One probe query.
struct ProbeIn {
  uvec4 key;    // x: PROBE_* op; y, z, w: op arguments
  vec4 o_tmax;  // ray origin, tMax
  vec4 d;       // ray direction (xyz)
  vec4 extra;   // op-specific
};

/// One probe answer. Misses report prim INVALID_INDEX and t = -1.
struct ProbeOut {
  vec4 f0;   // CLOSEST/RESPAWN: t, b1, b2, unused
  vec4 f1;   // RESPAWN: second hit t, b1, b2, unused
  uvec4 u;   // x: prim of first hit (or occluded flag), y: prim of second hit
};

#ifdef __cplusplus
static_assert(sizeof(ProbeIn) == 64 && sizeof(ProbeOut) == 48, "Probe layout");
static_assert(sizeof(Globals) == 64 + 4 * 16 + 4 * 16, "Globals layout");
static_assert(sizeof(BvhNode) == 32 && offsetof(BvhNode, hi) == 16, "BvhNode layout");
static_assert(sizeof(Triangle) == 16, "Triangle layout");
static_assert(sizeof(Vertex) == 32, "Vertex layout");
static_assert(sizeof(Mesh) == 16, "Mesh layout");
static_assert(sizeof(Sphere) == 80 && offsetof(Sphere, material) == 64, "Sphere layout");
static_assert(sizeof(Material) == 176 && offsetof(Material, texture) == 144, "Material layout");
static_assert(sizeof(Light) == 80 && offsetof(Light, L) == 16, "Light layout");
static_assert(sizeof(PassConstants) == 32, "PassConstants layout");
}  // namespace basalt::gpu
#endif

#endif  // BASALT_LAYOUT_H
