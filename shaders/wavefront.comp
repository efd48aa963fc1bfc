#version 460
// The wavefront stages of the path tracer (docs/performance.md, issue 12; in the manner of
// pbrt-v4's GPU path): the megakernel's path loop (include/integrator.glsl) cut at the
// intersection, over one wave of paths (up to `capacity` (sample, pixel slot) pairs in order:
// a small image's wave holds several samples) kept in a storage buffer (layout.h, WF_*). Built twice
// (CMakeLists.txt), one stage a module, so that neither holds the other's code:
// BASALT_WF_STAGE 0 (extend): start the paths (iteration 0) or take the active list, trace
// each path's ray, add the escaped radiance of a miss, and queue a hit by its material's type.
// BASALT_WF_STAGE 1 (shade): path_bounce over the queue of one material type (pc.pad0), the
// pipeline specialised for that type alone, so that each dispatch runs one material's code
// over its paths and compiles as a smaller shader. A path that ends leaves its radiance in
// its own words, which the host adds to the pixels in sample order after the wave (several
// paths of a pixel in a wave: no race, and the sums of one sample a wave).
// BASALT_WF_STAGE 2 (escape; scenes with an image infinite light only): the escaped radiance
// of the paths the extend stage queued on WF_LIST_ESCAPE. lavapipe runs an `if`'s code for
// every lane, so in the extend stage the environment map's lookup and density cost every path,
// hit or not; in a stage of its own they cost the paths that escaped (pbrt-v4's GPU path has
// the same stage, HandleEscapedRays).
#extension GL_GOOGLE_include_directive : require
#extension GL_EXT_control_flow_attributes : require
#extension GL_EXT_shader_explicit_arithmetic_types_int64 : require

#include "include/bindings.glsl"
#include "include/integrator.glsl"

layout(local_size_x = 64) in;

#if !defined(BASALT_WF_STAGE) || (BASALT_WF_STAGE < 0 || BASALT_WF_STAGE > 2)
#error "wavefront.comp is built with BASALT_WF_STAGE 0 (extend), 1 (shade) or 2 (escape)"
#endif

layout(push_constant) uniform Pass {
  PassConstants pc;
};

// A path between stages: the PathState, the hit of its ray.
struct WfPath {
  vec4 v[WF_PATH_VEC4S];
};
layout(std430, set = 0, binding = BINDING_PROBE_IN) restrict buffer WfPathBuffer {
  WfPath wf_paths[];
};
// The same paths as a uniform texel view (R32G32B32A32_UINT): lavapipe fetches texels without
// the per-lane loop of its storage-buffer loads (bindings.glsl).
layout(set = 0, binding = BINDING_WF_PATH_TEXELS) uniform usamplerBuffer wf_path_texels;
layout(std430, set = 0, binding = BINDING_PROBE_OUT) restrict buffer WfListBuffer {
  uint wf_lists[];  // WF_COUNTERS counters, then WF_LISTS lists of pc.pad1 entries
};

// Entry k of list l.
uint wf_entry(uint l, uint k) { return WF_COUNTERS + l * pc.pad1 + k; }

// Appends path id to list l.
void wf_push(uint l, uint id) { wf_lists[wf_entry(l, atomicAdd(wf_lists[l], 1u))] = id; }

// Stores path id: its state and the hit of its ray.
void wf_store(uint id, PathState ps, Hit hit) {
  uint flags = (ps.specular ? 1u : 0u) | (ps.has_diff ? 2u : 0u);
  wf_paths[id].v = vec4[WF_PATH_VEC4S](
      vec4(ps.ray.o, ps.ray.tmax), vec4(ps.ray.d, ps.pdf_prev), vec4(ps.L, ps.eta_scale),
      vec4(ps.beta, ps.m_prev), vec4(ps.p_prev, uintBitsToFloat(flags)),
      vec4(ps.ng_prev, uintBitsToFloat(ps.depth)), vec4(ps.ns_prev, uintBitsToFloat(ps.crossings)),
      vec4(ps.rd.rx_o, uintBitsToFloat(ps.px)), vec4(ps.rd.rx_d, uintBitsToFloat(ps.py)),
      vec4(ps.rd.ry_o, uintBitsToFloat(ps.s)), vec4(ps.rd.ry_d, uintBitsToFloat(ps.rays)),
      vec4(hit.t, hit.b1, hit.b2, uintBitsToFloat(hit.prim)));
}

// The ray of path id (wf_store's first two texels): all that the extend stage reads of a
// path it resumes.
Ray wf_load_ray(uint id) {
  vec4 v0 = uintBitsToFloat(texelFetch(wf_path_texels, int(id * WF_PATH_VEC4S)));
  vec4 v1 = uintBitsToFloat(texelFetch(wf_path_texels, int(id * WF_PATH_VEC4S + 1u)));
  return Ray(v0.xyz, v0.w, v1.xyz);
}

// Loads path id (wf_store's inverse).
PathState wf_load(uint id, out Hit hit) {
  vec4 v[WF_PATH_VEC4S];
  [[unroll]] for (uint k = 0u; k < WF_PATH_VEC4S; ++k)
    v[k] = uintBitsToFloat(texelFetch(wf_path_texels, int(id * WF_PATH_VEC4S + k)));
  PathState ps;
  ps.ray = Ray(v[0].xyz, v[0].w, v[1].xyz);
  ps.pdf_prev = v[1].w;
  ps.L = v[2].xyz;
  ps.eta_scale = v[2].w;
  ps.beta = v[3].xyz;
  ps.m_prev = v[3].w;
  ps.p_prev = v[4].xyz;
  uint flags = floatBitsToUint(v[4].w);
  ps.specular = (flags & 1u) != 0u;
  ps.has_diff = (flags & 2u) != 0u;
  ps.ng_prev = v[5].xyz;
  ps.depth = floatBitsToUint(v[5].w);
  ps.ns_prev = v[6].xyz;
  ps.crossings = floatBitsToUint(v[6].w);
  ps.rd = RayDiff(v[7].xyz, v[8].xyz, v[9].xyz, v[10].xyz);
  ps.px = floatBitsToUint(v[7].w);
  ps.py = floatBitsToUint(v[8].w);
  ps.s = floatBitsToUint(v[9].w);
  ps.rays = floatBitsToUint(v[10].w);
  hit = Hit(v[11].x, v[11].y, v[11].z, floatBitsToUint(v[11].w));
  return ps;
}

// Path id has ended: its radiance and pixel go to its radiance words, which the host adds to
// the pixel after the wave (a NaN or infinity is dropped and counted, as in render.comp), and
// its rays to the ray count.
void wf_finish(uint id, PathState ps) {
  vec3 L = ps.L;
  if (any(isnan(L)) || any(isinf(L))) {
    L = vec3(0.0);
    atomicAdd(counters[1], 1u);
  }
  uint at = WF_COUNTERS + WF_LISTS * pc.pad1 + id * WF_RADIANCE_WORDS;
  wf_lists[at] = floatBitsToUint(L.x);
  wf_lists[at + 1u] = floatBitsToUint(L.y);
  wf_lists[at + 2u] = floatBitsToUint(L.z);
  wf_lists[at + 3u] = ps.py * globals.image.x + ps.px;
  atomicAdd(counters[0], ps.rays);
}

// Stage 0: start or resume a path, trace its ray, finish it on a miss (or queue it for the
// escape stage, with an image infinite light), else queue it by the type of the material it
// hit (MATERIAL_NONE for none).
void extend() {
  uint gid = gl_GlobalInvocationID.x;
  if (gid >= pc.pixel_count) return;
  uint id;
  PathState ps;
  Hit hit;
  if (pc.sample_count == 0u) {
    // The wave runs the (sample, slot) pairs in order from slot pixel_offset of sample
    // sample_start: invocation gid takes the pair pixel_offset + gid places on.
    id = gid;
    uint t = pc.pixel_offset + gid;
    uint px, py;
    if (!slot_pixel(t % pc.pixel_total, pc.pixel_stride, pc.pixel_total, px, py)) return;
    ps = path_start(px, py, pc.sample_start + t / pc.pixel_total);
  } else {
    id = wf_lists[wf_entry(pc.pad0, gid)];
    ps.ray = wf_load_ray(id);
  }
  hit = intersect_closest(ps.ray);
  bool escaped = hit.prim == INVALID_INDEX;
  if (escaped && no_feature(FEATURE_LIGHT_INFINITE_IMAGE)) {
    if (pc.sample_count != 0u) {
      Hit stale;
      ps = wf_load(id, stale);
    }
    ++ps.rays;  // this stage's ray (a path that goes on: counted by the stage that loads it)
    path_escape(ps);
    wf_finish(id, ps);
    return;
  }
  // One store and one push for both lists (lavapipe runs every call site for every lane).
  uint list = WF_LIST_ESCAPE;
  if (!escaped) {
    uint m = hit_material(hit);
    uint type = m == INVALID_INDEX ? MATERIAL_NONE : material_head(m).x;
    if (type >= MATERIAL_TYPE_COUNT) type = MATERIAL_NONE;
    list = WF_LIST_QUEUE + type;
  }
  // A started path is stored whole, a resumed one only its hit: the rest of its record is
  // unchanged (it cost 12 texels read and 12 written, each a per-lane access on lavapipe).
  if (pc.sample_count == 0u)
    wf_store(id, ps, hit);
  else
    wf_paths[id].v[WF_PATH_VEC4S - 1u] = vec4(hit.t, hit.b1, hit.b2, uintBitsToFloat(hit.prim));
  wf_push(list, id);
}

// Stage 1: one bounce of each path in queue pc.pad0 & 0xffff; a path that goes on joins the
// active list pc.pad0 >> 16.
void shade() {
  uint gid = gl_GlobalInvocationID.x;
  if (gid >= pc.pixel_count) return;
  uint id = wf_lists[wf_entry(pc.pad0 & 0xffffu, gid)];
  Hit hit;
  PathState ps = wf_load(id, hit);
  ++ps.rays;  // the extend stage's ray to this hit
  if (path_bounce(ps, hit)) {
    wf_store(id, ps, hit);
    wf_push(pc.pad0 >> 16u, id);
  } else {
    wf_finish(id, ps);
  }
}

// Stage 2: the escaped radiance of each path on WF_LIST_ESCAPE, which ends there.
void escape() {
  uint gid = gl_GlobalInvocationID.x;
  if (gid >= pc.pixel_count) return;
  uint id = wf_lists[wf_entry(WF_LIST_ESCAPE, gid)];
  Hit hit;
  PathState ps = wf_load(id, hit);
  ++ps.rays;  // the extend stage's ray that escaped
  path_escape(ps);
  wf_finish(id, ps);
}

void main() {
#if BASALT_WF_STAGE == 0
  extend();
#elif BASALT_WF_STAGE == 1
  shade();
#else
  escape();
#endif
}
