// Hand-built SceneTables for the CPU reference tests: meshes, spheres, lights and a small
// median-split BVH, with no parser or table builder involved.
#pragma once
#include <algorithm>
#include <cstdint>
#include <numeric>
#include <vector>

#include <glm/glm.hpp>

#include "cpu/sampling.h"
#include "cpu/wide_bvh.h"
#include "scene/tables.h"

namespace basalt::cpu::test_scene {

/// Builder of a small scene; call finish() before rendering.
struct TestScene {
  SceneTables t;

  /// Pinhole camera at the origin looking down +z, 90 degree field of view, box filter.
  explicit TestScene(std::uint32_t w = 8, std::uint32_t h = 8, std::uint32_t max_depth = 5) {
    gpu::Globals& g = t.globals;
    g.world_from_camera = glm::mat4(1.0f);
    g.camera_from_world = glm::mat4(1.0f);
    g.screen = glm::vec4(-1.0f, 1.0f, -1.0f, 1.0f);
    g.lens = glm::vec4(1.0f, 0.0f, 1e6f, 0.0f);
    g.filter_radius = glm::vec4(0.5f, 0.5f, 0.0f, 0.0f);
    g.image = glm::uvec4(w, h, max_depth, 0u);
    g.counts = glm::uvec4(0u, 0u, gpu::FILTER_BOX, 0u);
    g.infinite_lights = glm::uvec4(gpu::INVALID_INDEX);
  }

  /// Adds a diffuse material of reflectance R; returns its index.
  std::uint32_t diffuse(glm::vec3 R) {
    gpu::Material m{};
    m.type = gpu::MATERIAL_DIFFUSE;
    m.value[gpu::SLOT_DIFFUSE_REFLECTANCE] = glm::vec4(R, 0.0f);
    for (auto& tx : m.texture) tx = glm::uvec4(gpu::INVALID_INDEX);
    t.materials.push_back(m);
    return std::uint32_t(t.materials.size() - 1);
  }

  /// Adds a triangle mesh (world-space positions, optional normals); returns the mesh index.
  std::uint32_t mesh(const std::vector<glm::vec3>& P, const std::vector<glm::uvec3>& idx,
                     std::uint32_t material, std::uint32_t flags = 0,
                     const std::vector<glm::vec3>& N = {}) {
    const std::uint32_t vbase = std::uint32_t(t.vertices.size());
    for (std::size_t i = 0; i < P.size(); ++i) {
      gpu::Vertex v{};
      v.p_u = glm::vec4(P[i], 0.0f);
      v.n_v = glm::vec4(N.empty() ? glm::vec3(0.0f) : N[i], 0.0f);
      t.vertices.push_back(v);
    }
    gpu::Mesh m{};
    m.material = material;
    m.light_base = gpu::INVALID_INDEX;
    m.tri_base = std::uint32_t(t.triangles.size());
    m.flags = flags | (N.empty() ? 0u : gpu::SHAPE_FLAG_HAS_NORMALS);
    t.meshes.push_back(m);
    const std::uint32_t mi = std::uint32_t(t.meshes.size() - 1);
    for (const glm::uvec3& f : idx) t.triangles.push_back({vbase + f.x, vbase + f.y, vbase + f.z, mi});
    return mi;
  }

  /// Adds a sphere; returns its sphere index.
  std::uint32_t sphere(glm::vec3 c, float r, std::uint32_t material, std::uint32_t flags = 0) {
    gpu::Sphere s{};
    s.center_radius = glm::vec4(c, r);
    s.axis_x = glm::vec4(1, 0, 0, 1);  // w: object-to-world scale
    s.axis_y = glm::vec4(0, 1, 0, 0);
    s.axis_z = glm::vec4(0, 0, 1, 0);
    s.material = material;
    s.light = gpu::INVALID_INDEX;
    s.flags = flags;
    t.spheres.push_back(s);
    return std::uint32_t(t.spheres.size() - 1);
  }

  /// Makes every triangle of mesh mi an area light of radiance L.
  void mesh_light(std::uint32_t mi, glm::vec3 L, bool twosided = false) {
    gpu::Mesh& m = t.meshes[mi];
    m.light_base = std::uint32_t(t.lights.size());
    const std::uint32_t end = mi + 1 < t.meshes.size() ? t.meshes[mi + 1].tri_base
                                                       : std::uint32_t(t.triangles.size());
    for (std::uint32_t tri = m.tri_base; tri < end; ++tri) {
      const gpu::Triangle& T = t.triangles[tri];
      const glm::vec3 p0(t.vertices[T.v0].p_u), p1(t.vertices[T.v1].p_u), p2(t.vertices[T.v2].p_u);
      gpu::Light l{};
      l.type = gpu::LIGHT_AREA_TRIANGLE;
      l.prim = tri;
      l.flags = twosided ? gpu::LIGHT_FLAG_TWOSIDED : 0u;
      l.L = glm::vec4(L, 0.0f);
      l.params = glm::vec4(0.5f * glm::length(glm::cross(p1 - p0, p2 - p0)), 0, 0, 0);
      t.lights.push_back(l);
    }
  }

  /// Makes sphere si an area light of radiance L.
  void sphere_light(std::uint32_t si, glm::vec3 L, bool twosided = false) {
    gpu::Light l{};
    l.type = gpu::LIGHT_AREA_SPHERE;
    l.prim = si;
    l.flags = twosided ? gpu::LIGHT_FLAG_TWOSIDED : 0u;
    l.L = glm::vec4(L, 0.0f);
    t.spheres[si].light = std::uint32_t(t.lights.size());
    t.lights.push_back(l);
  }

  /// Adds a non-area light (point, spot, distant, infinite) as given.
  void light(const gpu::Light& l) { t.lights.push_back(l); }

  /// Uniform light pmf and CDF, infinite light list, BVH (leaves of at most leaf_size prims).
  void finish(std::uint32_t leaf_size = 2) {
    const std::uint32_t n = std::uint32_t(t.lights.size());
    t.light_cdf.assign(n + 1, 0.0f);
    std::uint32_t ninf = 0;
    for (std::uint32_t i = 0; i < n; ++i) {
      t.lights[i].pmf = 1.0f / float(n);
      t.light_cdf[i + 1] = float(i + 1) / float(n);
      if (t.lights[i].type == gpu::LIGHT_INFINITE_UNIFORM && ninf < gpu::MAX_INFINITE_LIGHTS)
        t.globals.infinite_lights[int(ninf++)] = i;
    }
    if (n > 0) t.light_cdf[n] = 1.0f;
    t.globals.counts.x = n;
    t.globals.counts.y = ninf;
    t.prim_refs.clear();
    for (std::uint32_t i = 0; i < t.triangles.size(); ++i) t.prim_refs.push_back(i);
    for (std::uint32_t i = 0; i < t.spheres.size(); ++i) t.prim_refs.push_back(i | gpu::PRIM_SPHERE_BIT);
    t.nodes.clear();
    if (t.prim_refs.empty()) return;
    t.nodes.resize(1);
    build(0, 0, std::uint32_t(t.prim_refs.size()), std::max(1u, leaf_size));
    t.cpu_wide = cpu::build_cpu_wide_bvh(t);  // the traversal the renderer uses (build_tables)
  }

  /// Bounds of one primitive reference.
  void bounds(std::uint32_t ref, glm::vec3& lo, glm::vec3& hi) const {
    if (ref & gpu::PRIM_SPHERE_BIT) {
      const gpu::Sphere& s = t.spheres[ref & gpu::PRIM_INDEX_MASK];
      lo = glm::vec3(s.center_radius) - s.center_radius.w;
      hi = glm::vec3(s.center_radius) + s.center_radius.w;
      return;
    }
    const gpu::Triangle& T = t.triangles[ref];
    const glm::vec3 p0(t.vertices[T.v0].p_u), p1(t.vertices[T.v1].p_u), p2(t.vertices[T.v2].p_u);
    lo = glm::min(p0, glm::min(p1, p2));
    hi = glm::max(p0, glm::max(p1, p2));
  }

  /// Object-median split on the longest centroid axis (test scaffolding, not a real builder).
  void build(std::uint32_t node, std::uint32_t begin, std::uint32_t end, std::uint32_t leaf) {
    glm::vec3 lo(1e30f), hi(-1e30f), clo(1e30f), chi(-1e30f);
    for (std::uint32_t i = begin; i < end; ++i) {
      glm::vec3 a, b;
      bounds(t.prim_refs[i], a, b);
      lo = glm::min(lo, a);
      hi = glm::max(hi, b);
      clo = glm::min(clo, 0.5f * (a + b));
      chi = glm::max(chi, 0.5f * (a + b));
    }
    t.nodes[node].lo = lo;
    t.nodes[node].hi = hi;
    if (end - begin <= leaf) {
      t.nodes[node].a = begin;
      t.nodes[node].b = end - begin;
      return;
    }
    const glm::vec3 ext = chi - clo;
    const int axis = ext.x > ext.y ? (ext.x > ext.z ? 0 : 2) : (ext.y > ext.z ? 1 : 2);
    const std::uint32_t mid = (begin + end) / 2;
    std::nth_element(t.prim_refs.begin() + begin, t.prim_refs.begin() + mid,
                     t.prim_refs.begin() + end, [&](std::uint32_t x, std::uint32_t y) {
                       glm::vec3 a0, b0, a1, b1;
                       bounds(x, a0, b0);
                       bounds(y, a1, b1);
                       return (a0 + b0)[axis] < (a1 + b1)[axis];
                     });
    const std::uint32_t c = std::uint32_t(t.nodes.size());
    t.nodes.resize(c + 2);
    t.nodes[node].a = c;
    t.nodes[node].b = 0;
    build(c, begin, mid, leaf);
    build(c + 1, mid, end, leaf);
  }
};

/// Closed unit cube [-1,1]^3 (scaled, then offset) as 12 triangles with outward winding.
inline void cube(std::vector<glm::vec3>& P, std::vector<glm::uvec3>& idx, float scale = 1.0f,
                 glm::vec3 offset = glm::vec3(0.0f)) {
  P.clear();
  idx.clear();
  for (int i = 0; i < 8; ++i)
    P.push_back(offset + scale * glm::vec3(i & 1 ? 1 : -1, i & 2 ? 1 : -1, i & 4 ? 1 : -1));
  // Faces as quads (a, b, c, d) counter-clockwise seen from outside.
  const int q[6][4] = {{0, 2, 3, 1}, {4, 5, 7, 6}, {0, 1, 5, 4},
                       {2, 6, 7, 3}, {0, 4, 6, 2}, {1, 3, 7, 5}};
  for (const auto& f : q) {
    idx.push_back(glm::uvec3(f[0], f[1], f[2]));
    idx.push_back(glm::uvec3(f[0], f[2], f[3]));
  }
}

}  // namespace basalt::cpu::test_scene
