// Numerical robustness of intersection and ray spawning, on both sides through the probe
// interface (shaders/tests/probe.comp and its twin basalt::cpu::probe): no
// self-intersection at any scale, watertight meshes, degenerate triangles, grazing rays;
// and CPU/GPU agreement of the random numbers, camera rays and their differentials.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <random>
#include <string>

#include <glm/gtc/matrix_transform.hpp>

#include "common/axis_rays.h"
#include "common/test_util.h"
#include "cpu/wide_bvh.h"

namespace basalt::test {
namespace {

constexpr float kPi = 3.14159265358979f;

/// Adds a triangle mesh shape (object space = world space).
void add_mesh(Scene& s, const std::vector<glm::vec3>& p, const std::vector<unsigned>& idx) {
  Shape sh;
  sh.kind = Shape::Kind::Triangles;
  sh.material = 0;
  sh.mesh.P = p;
  sh.mesh.indices = idx;
  s.shapes.push_back(sh);
}

/// Adds a sphere at \p c of radius \p r.
void add_sphere(Scene& s, glm::vec3 c, float r) {
  Shape sh;
  sh.kind = Shape::Kind::Sphere;
  sh.material = 0;
  sh.radius = r;
  sh.world_from_object = glm::translate(glm::mat4(1.0f), c);
  s.shapes.push_back(sh);
}

/// A probe query.
gpu::ProbeIn query(std::uint32_t op, glm::vec3 o, glm::vec3 d, float tmax = 3.4e38f,
                   glm::vec3 extra = glm::vec3(0.0f)) {
  return gpu::ProbeIn{glm::uvec4(op, 0, 0, 0), glm::vec4(o, tmax), glm::vec4(d, 0.0f),
                      glm::vec4(extra, 0.0f), glm::vec4(0.0f), glm::vec4(0.0f)};
}

/// Uniform random direction.
glm::vec3 random_dir(std::mt19937& rng) {
  std::uniform_real_distribution<float> u(0.0f, 1.0f);
  float z = 1.0f - 2.0f * u(rng), r = std::sqrt(std::max(0.0f, 1.0f - z * z)),
        phi = 2.0f * kPi * u(rng);
  return {r * std::cos(phi), r * std::sin(phi), z};
}

class Robustness : public ::testing::TestWithParam<Side> {};

// Rays leaving a hit point, into either hemisphere, never re-hit their own triangle; for a
// sphere, a ray into the inside may only hit the far side, never near its origin.
// Random triangles and spheres at scales 1e-4 .. 1e6.
TEST_P(Robustness, NoSelfIntersectionAtAnyScale) {
  for (float scale : {1e-4f, 1e-2f, 1.0f, 1e2f, 1e4f, 1e6f}) {
    std::mt19937 rng(1234);
    std::uniform_real_distribution<float> u(-1.0f, 1.0f), u01(0.0f, 1.0f);
    Scene s = one_material_scene();
    std::vector<glm::vec3> p;
    std::vector<unsigned> idx;
    const glm::vec3 offset(scale * 3.0f, -scale * 2.0f, scale * 5.0f);  // away from the origin
    for (int i = 0; i < 200; ++i) {
      glm::vec3 c = offset + scale * glm::vec3(u(rng), u(rng), u(rng));
      for (int k = 0; k < 3; ++k) {
        idx.push_back(unsigned(p.size()));
        p.push_back(c + 0.3f * scale * glm::vec3(u(rng), u(rng), u(rng)));
      }
    }
    add_mesh(s, p, idx);
    std::vector<std::pair<glm::vec3, float>> spheres;
    for (int i = 0; i < 40; ++i) {
      glm::vec3 c = offset + scale * glm::vec3(u(rng), u(rng), u(rng));
      float r = scale * (0.02f + 0.2f * u01(rng));
      add_sphere(s, c, r);
      spheres.push_back({c, r});
    }
    SceneTables t = build_tables(s);
    std::vector<gpu::ProbeIn> q;
    for (int i = 0; i < 4000; ++i) {
      glm::vec3 target;
      if (i % 4 != 3) {  // a random point on a random triangle
        int k = int(u01(rng) * 199.99f);
        float b1 = u01(rng), b2 = u01(rng);
        if (b1 + b2 > 1) b1 = 1 - b1, b2 = 1 - b2;
        target = (1 - b1 - b2) * p[3 * k] + b1 * p[3 * k + 1] + b2 * p[3 * k + 2];
      } else {  // a random point on a random sphere
        auto [c, r] = spheres[std::size_t(u01(rng) * 39.99f)];
        target = c + r * random_dir(rng);
      }
      glm::vec3 o = target + 4.0f * scale * random_dir(rng);
      q.push_back(query(gpu::PROBE_RESPAWN, o, target - o, 3.4e38f, random_dir(rng)));
    }
    auto out = probe(GetParam(), t, q);
    int hits = 0, self = 0;
    for (std::size_t i = 0; i < q.size(); ++i) {
      if (out[i].u.x == gpu::INVALID_INDEX) continue;
      ++hits;
      ASSERT_TRUE(std::isfinite(out[i].f0.x));
      if (out[i].u.y != out[i].u.x) continue;
      if (out[i].u.x & gpu::PRIM_SPHERE_BIT) {
        // Same sphere again: legitimate only as the far side, a chord 2 r cos away when
        // leaving inwards; never when leaving outwards. Near-tangent directions, where
        // either is a matter of rounding, are not judged.
        const glm::vec4 cr = t.spheres[out[i].u.x & gpu::PRIM_INDEX_MASK].center_radius;
        const glm::vec3 hit = glm::vec3(q[i].o_tmax) + out[i].f0.x * glm::vec3(q[i].d);
        const glm::vec3 n = glm::normalize(hit - glm::vec3(cr));
        const glm::vec3 wi = glm::vec3(q[i].extra);
        const float chord = -2.0f * cr.w * glm::dot(wi, n) / glm::length(wi);
        if (chord < -1e-3f * cr.w) ++self;  // left outwards, came back
        if (chord > 1e-3f * cr.w && out[i].f1.x * glm::length(wi) < 0.5f * chord) ++self;
      } else {
        ++self;
      }
    }
    EXPECT_GT(hits, 3000) << "scale " << scale;
    EXPECT_EQ(self, 0) << "scale " << scale << ": self-intersections";
  }
}

// A closed mesh (a UV sphere with shared vertices and pole fans) is watertight: rays from
// inside aimed exactly at its vertices and at points on its edges always hit it.
TEST_P(Robustness, ClosedMeshIsWatertight) {
  for (float scale : {1e-3f, 1.0f, 1e4f}) {
    const int nu = 48, nv = 24;
    std::vector<glm::vec3> p;
    std::vector<unsigned> idx;
    const glm::vec3 c(scale * 7.0f, scale * 3.0f, -scale * 11.0f);
    p.push_back(c + scale * glm::vec3(0, 1, 0));  // north pole
    for (int j = 1; j < nv; ++j)
      for (int i = 0; i < nu; ++i) {
        float th = kPi * j / nv, ph = 2 * kPi * i / nu;
        p.push_back(c + scale * glm::vec3(std::sin(th) * std::cos(ph), std::cos(th),
                                          std::sin(th) * std::sin(ph)));
      }
    p.push_back(c + scale * glm::vec3(0, -1, 0));  // south pole
    auto ring = [&](int j, int i) { return unsigned(1 + (j - 1) * nu + (i % nu)); };
    const unsigned south = unsigned(p.size() - 1);
    std::vector<std::pair<unsigned, unsigned>> edges;
    for (int i = 0; i < nu; ++i) {
      idx.insert(idx.end(), {0u, ring(1, i + 1), ring(1, i)});
      idx.insert(idx.end(), {south, ring(nv - 1, i), ring(nv - 1, i + 1)});
      edges.push_back({0u, ring(1, i)});
      edges.push_back({south, ring(nv - 1, i)});
      for (int j = 1; j < nv - 1; ++j) {
        idx.insert(idx.end(), {ring(j, i), ring(j, i + 1), ring(j + 1, i + 1)});
        idx.insert(idx.end(), {ring(j, i), ring(j + 1, i + 1), ring(j + 1, i)});
        edges.push_back({ring(j, i), ring(j, i + 1)});
        edges.push_back({ring(j, i), ring(j + 1, i + 1)});
        edges.push_back({ring(j, i), ring(j + 1, i)});
      }
    }
    Scene s = one_material_scene();
    add_mesh(s, p, idx);
    SceneTables t = build_tables(s);
    std::mt19937 rng(99);
    std::uniform_real_distribution<float> u01(0.0f, 1.0f);
    std::vector<gpu::ProbeIn> q;
    for (const auto& v : p) {  // every vertex, from the centre and from random inner points
      q.push_back(query(gpu::PROBE_CLOSEST, c, v - c));
      glm::vec3 o = c + 0.5f * scale * u01(rng) * random_dir(rng);
      q.push_back(query(gpu::PROBE_CLOSEST, o, v - o));
    }
    for (const auto& [a, b] : edges) {  // midpoints and random points of every edge
      for (float f : {0.5f, u01(rng), u01(rng)}) {
        glm::vec3 target = p[a] + f * (p[b] - p[a]);
        glm::vec3 o = c + 0.5f * scale * u01(rng) * random_dir(rng);
        q.push_back(query(gpu::PROBE_CLOSEST, o, target - o));
      }
    }
    auto out = probe(GetParam(), t, q);
    int misses = 0;
    for (const auto& r : out) misses += r.u.x == gpu::INVALID_INDEX;
    EXPECT_EQ(misses, 0) << "scale " << scale << ": " << misses << " of " << q.size()
                         << " rays leaked through the mesh";
  }
}

// Zero-area triangles (collinear or repeated vertices) are never hit and produce no NaN;
// the triangle behind them is hit instead. The builder drops degenerate triangles, so
// they are planted into the tables after the build (the BVH bounds still cover them).
TEST_P(Robustness, DegenerateTrianglesAreSkipped) {
  Scene s = one_material_scene();
  // Two front triangles at z = 0 (to be made degenerate) and a back quad at z = 1.
  add_mesh(s,
           {{-1, -1, 0}, {1, -1, 0}, {1, 1, 0}, {-1, 1, 0},  // front quad
            {-2, -2, 1}, {2, -2, 1}, {2, 2, 1}, {-2, 2, 1}},  // back quad
           {0, 1, 2, 0, 2, 3, 4, 5, 6, 4, 6, 7});
  SceneTables t = build_tables(s);
  ASSERT_EQ(t.triangles.size(), 4u);
  // Triangle 0: collinear (v2 on the segment v0 v1); triangle 1: repeated vertex.
  t.vertices[t.triangles[0].v2].p_u = 0.5f * (t.vertices[t.triangles[0].v0].p_u +
                                              t.vertices[t.triangles[0].v1].p_u);
  t.vertices[t.triangles[1].v2].p_u = t.vertices[t.triangles[1].v0].p_u;
  t.cpu_wide = cpu::build_cpu_wide_bvh(t);  // the CPU reference's copy of the corners
  std::vector<gpu::ProbeIn> q;
  std::mt19937 rng(5);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int i = 0; i < 2000; ++i) {
    glm::vec3 target(u(rng), u(rng), 0.0f);
    if (i < 20) target = glm::vec3(t.vertices[t.triangles[0].v0].p_u);  // on the degenerate vertex
    glm::vec3 o(0.1f * u(rng), 0.1f * u(rng), -3.0f);
    q.push_back(query(gpu::PROBE_RESPAWN, o, target - o, 3.4e38f, random_dir(rng)));
  }
  auto out = probe(GetParam(), t, q);
  for (std::size_t i = 0; i < out.size(); ++i) {
    ASSERT_NE(out[i].u.x, 0u) << "hit the collinear triangle";
    ASSERT_NE(out[i].u.x, 1u) << "hit the repeated-vertex triangle";
    ASSERT_NE(out[i].u.x, gpu::INVALID_INDEX) << "missed the back quad";
    ASSERT_TRUE(std::isfinite(out[i].f0.x) && std::isfinite(out[i].f0.y) &&
                std::isfinite(out[i].f0.z));
    ASSERT_TRUE(std::isfinite(out[i].f1.x));
  }
}

// Grazing rays: shallow angles hit a plane at the analytic distance; rays in the plane and
// tangent to a sphere give a finite answer (hit or miss), never NaN.
TEST_P(Robustness, GrazingRays) {
  Scene s = one_material_scene();
  add_mesh(s, {{-100, 0, -100}, {100, 0, -100}, {100, 0, 100}, {-100, 0, 100}},
           {0, 1, 2, 0, 2, 3});
  add_sphere(s, {0, 5, 0}, 1.0f);
  SceneTables t = build_tables(s);
  std::vector<gpu::ProbeIn> q;
  std::vector<float> expect_t;
  for (float eps : {1e-1f, 1e-2f, 1e-3f, 1e-4f, 1e-5f}) {
    // From height h, descending with slope eps: the plane is reached at x = h / eps.
    float h = 50.0f * eps;
    q.push_back(query(gpu::PROBE_CLOSEST, {-50.0f, h, 3.0f}, {1.0f, -eps, 0.0f}));
    expect_t.push_back(h / eps);
  }
  const std::size_t analytic = q.size();
  q.push_back(query(gpu::PROBE_CLOSEST, {-50, 0, 3}, {1, 0, 0}));     // in the plane
  q.push_back(query(gpu::PROBE_CLOSEST, {-50, 6, 0}, {1, 0, 0}));     // tangent to the sphere
  q.push_back(query(gpu::PROBE_CLOSEST, {-50, 5, 1}, {1, 0, 0}));     // tangent, other side
  q.push_back(query(gpu::PROBE_CLOSEST, {0, 50, 0}, {0, -1, 0}));     // axis-aligned, poles
  q.push_back(query(gpu::PROBE_OCCLUDED, {-50, 1e-6f, 3}, {1, 0, 0})); // just above the plane
  auto out = probe(GetParam(), t, q);
  for (std::size_t i = 0; i < analytic; ++i) {
    ASSERT_NE(out[i].u.x, gpu::INVALID_INDEX) << i;
    EXPECT_NEAR(out[i].f0.x, expect_t[i], 1e-3f * expect_t[i]) << i;
  }
  for (std::size_t i = analytic; i < out.size(); ++i)
    for (int k = 0; k < 3; ++k) EXPECT_TRUE(std::isfinite(out[i].f0[k])) << i;
  // Straight down onto the sphere's pole: t = 50 - 6 = 44.
  EXPECT_NEAR(out[analytic + 3].f0.x, 44.0f, 1e-4f);
  EXPECT_EQ(out[analytic + 3].u.x, gpu::PRIM_SPHERE_BIT | 0u);
}

// Rays along an axis (a direction component of +0, -0 or below 1e-20) whose origin lies in a
// face plane of the box ahead (docs/path-spec.md 3: such an axis bounds nothing when the origin
// is in the slab, faces included): the finite stand-in for 1 / 0 made them leave the slab at
// t = 0, so both sides missed the vertex on that face (Stress.Closest found the CPU and the
// GPU's wide boxes disagreeing on them). One triangle, so the box faces are its extremes.
TEST_P(Robustness, AxisRaysInAFacePlaneMeetThePrimitivesAhead) {
  Scene s = one_material_scene();
  add_mesh(s, axis_ray_triangle(), {0, 1, 2});
  SceneTables t = build_tables(s);
  const std::vector<AxisRayCase> cases = axis_ray_cases();
  std::vector<gpu::ProbeIn> q;
  for (const AxisRayCase& c : cases) {
    q.push_back(query(gpu::PROBE_CLOSEST, c.o, c.d));
    q.push_back(query(gpu::PROBE_OCCLUDED, c.o, c.d, 6.0f));
    q.push_back(query(gpu::PROBE_OCCLUDED, c.o, c.d, 4.0f));  // ends before the triangle
  }
  auto out = probe(GetParam(), t, q);
  for (std::size_t i = 0; i < cases.size(); ++i) {
    const gpu::ProbeOut& closest = out[3 * i];
    if (cases[i].hit) {
      EXPECT_EQ(closest.u.x, 0u) << "case " << i;
      EXPECT_EQ(closest.f0.x, 5.0f) << "case " << i;
    } else {
      EXPECT_EQ(closest.u.x, gpu::INVALID_INDEX) << "case " << i;
    }
    EXPECT_EQ(out[3 * i + 1].u.x, cases[i].hit ? 1u : 0u) << "case " << i;
    EXPECT_EQ(out[3 * i + 2].u.x, 0u) << "case " << i;
  }
}

INSTANTIATE_TEST_SUITE_P(BothSides, Robustness, ::testing::Values(Side::Cpu, Side::Gpu),
                         [](const auto& info) { return side_name(info.param); });

// The counter-based generator gives bit-identical numbers on both sides.
TEST(ProbeConformance, RngIsBitIdentical) {
  SceneTables t = build_tables(one_material_scene());
  set_seed(t, 424242u);
  std::vector<gpu::ProbeIn> q;
  std::mt19937 rng(3);
  for (int i = 0; i < 20000; ++i) {
    gpu::ProbeIn in{};
    in.key = glm::uvec4(gpu::PROBE_RNG, rng() % 4096, rng() % 4096, rng() % 100000);
    in.extra.x = std::bit_cast<float>(std::uint32_t(rng() % 4096));
    q.push_back(in);
  }
  auto cpu = probe(Side::Cpu, t, q), gpu = probe(Side::Gpu, t, q);
  int diff = 0;
  double sum = 0.0;
  for (std::size_t i = 0; i < q.size(); ++i) {
    diff += std::bit_cast<std::uint32_t>(cpu[i].f0.x) != std::bit_cast<std::uint32_t>(gpu[i].f0.x);
    ASSERT_GE(cpu[i].f0.x, 0.0f);
    ASSERT_LT(cpu[i].f0.x, 1.0f);
    sum += cpu[i].f0.x;
  }
  EXPECT_EQ(diff, 0);
  EXPECT_NEAR(sum / q.size(), 0.5, 0.01);
}

// Camera rays agree between the sides (within float rounding), for a thin-lens camera.
TEST(ProbeConformance, CameraRaysAgree) {
  Scene s = one_material_scene();
  s.film.xres = 64;
  s.film.yres = 48;
  s.camera.lens_radius = 0.1f;
  s.camera.focal_distance = 5.0f;
  s.camera.fov_deg = 50.0f;
  s.filter.type = Filter::Type::Gaussian;
  SceneTables t = build_tables(s);
  std::vector<gpu::ProbeIn> q;
  for (std::uint32_t y = 0; y < 48; y += 3)
    for (std::uint32_t x = 0; x < 64; x += 3)
      for (std::uint32_t smp = 0; smp < 4; ++smp) {
        gpu::ProbeIn in{};
        in.key = glm::uvec4(gpu::PROBE_CAMERA, x, y, smp);
        q.push_back(in);
      }
  auto cpu = probe(Side::Cpu, t, q), gpu = probe(Side::Gpu, t, q);
  for (std::size_t i = 0; i < q.size(); ++i)
    for (int k = 0; k < 3; ++k) {
      ASSERT_NEAR(cpu[i].f0[k], gpu[i].f0[k], 1e-5f) << i;
      ASSERT_NEAR(cpu[i].f1[k], gpu[i].f1[k], 1e-5f) << i;
    }
}

/// Camera queries of \p op over a grid of pixels (every third, plus the last row and
/// column) and 4 samples each, for a 64x48 film.
std::vector<gpu::ProbeIn> camera_queries(std::uint32_t op) {
  std::vector<gpu::ProbeIn> q;
  for (std::uint32_t y = 0; y < 48; y = y == 45 ? 47 : y + 3)  // 0, 3, ..., 45, 47
    for (std::uint32_t x = 0; x < 64; x += 3)                    // 0, 3, ..., 63
      for (std::uint32_t smp = 0; smp < 4; ++smp) {
        gpu::ProbeIn in{};
        in.key = glm::uvec4(op, x, y, smp);
        q.push_back(in);
      }
  return q;
}

// Camera ray differentials (spec section 2 step 6) agree between the sides, for a thin-lens
// camera with a gaussian filter and a rotated, translated pinhole camera with a box filter.
TEST(ProbeConformance, CameraDifferentialsAgree) {
  for (bool thin_lens : {true, false}) {
    SCOPED_TRACE(thin_lens ? "thin lens" : "pinhole");
    Scene s = one_material_scene();
    s.film.xres = 64;
    s.film.yres = 48;
    s.camera.fov_deg = 50.0f;
    if (thin_lens) {
      s.camera.lens_radius = 0.1f;
      s.camera.focal_distance = 5.0f;
      s.filter.type = Filter::Type::Gaussian;
    } else {
      s.camera.world_from_camera =
          glm::rotate(glm::translate(glm::mat4(1.0f), glm::vec3(1.0f, -2.0f, 3.0f)), 0.7f,
                      glm::normalize(glm::vec3(1.0f, 2.0f, -0.5f)));
    }
    SceneTables t = build_tables(s);
    const std::vector<gpu::ProbeIn> q = camera_queries(gpu::PROBE_CAMERA_DIFF);
    auto cpu = probe(Side::Cpu, t, q), gpu = probe(Side::Gpu, t, q);
    ASSERT_EQ(cpu.size(), q.size());
    ASSERT_EQ(gpu.size(), q.size());
    for (std::size_t i = 0; i < q.size(); ++i) {
      ASSERT_NEAR(glm::length(glm::vec3(cpu[i].f0)), 1.0f, 1e-6f) << i;
      ASSERT_NEAR(glm::length(glm::vec3(cpu[i].f1)), 1.0f, 1e-6f) << i;
      for (int k = 0; k < 3; ++k) {
        ASSERT_NEAR(cpu[i].f0[k], gpu[i].f0[k], 1e-5f) << i;
        ASSERT_NEAR(cpu[i].f1[k], gpu[i].f1[k], 1e-5f) << i;
      }
    }
  }
}

class CameraDifferentials : public ::testing::TestWithParam<Side> {};

// Pinhole 64x48, fov 50 on the shorter (y) axis, camera at the origin looking down +z with
// up +y (Scene's default world_from_camera = identity): projected onto the z = 1 plane, the
// rx direction is one pixel, 2 tan(fov/2) / 48, further in +x than the ray's, and the ry
// direction one pixel further in -y (raster y goes down, screen y up); the other axis does
// not move.
TEST_P(CameraDifferentials, PinholeAnalytic) {
  Scene s = one_material_scene();
  s.film.xres = 64;
  s.film.yres = 48;
  s.camera.fov_deg = 50.0f;
  SceneTables t = build_tables(s);
  const std::vector<gpu::ProbeIn> qc = camera_queries(gpu::PROBE_CAMERA);
  const std::vector<gpu::ProbeIn> qd = camera_queries(gpu::PROBE_CAMERA_DIFF);
  std::vector<gpu::ProbeIn> q = qc;
  q.insert(q.end(), qd.begin(), qd.end());
  const auto out = probe(GetParam(), t, q);
  ASSERT_EQ(out.size(), q.size());
  const double pixel = 2.0 * std::tan(25.0 * 3.14159265358979323846 / 180.0) / 48.0;
  auto plane = [](const glm::vec4& d) { return glm::dvec2(d.x, d.y) / double(d.z); };
  for (std::size_t i = 0; i < qc.size(); ++i) {
    const gpu::ProbeOut& cam = out[i];
    const gpu::ProbeOut& diff = out[qc.size() + i];
    ASSERT_EQ(glm::vec3(cam.f0), glm::vec3(0.0f)) << i;  // pinhole origin
    const glm::dvec2 p = plane(cam.f1), px = plane(diff.f0), py = plane(diff.f1);
    const std::string where = "pixel (" + std::to_string(q[i].key.y) + ", " +
                              std::to_string(q[i].key.z) + ") sample " + std::to_string(q[i].key.w);
    EXPECT_NEAR(px.x - p.x, pixel, 1e-4 * pixel) << where;
    EXPECT_NEAR(px.y - p.y, 0.0, 1e-4 * pixel) << where;
    EXPECT_NEAR(py.x - p.x, 0.0, 1e-4 * pixel) << where;
    EXPECT_NEAR(py.y - p.y, -pixel, 1e-4 * pixel) << where;
  }
}

INSTANTIATE_TEST_SUITE_P(BothSides, CameraDifferentials, ::testing::Values(Side::Cpu, Side::Gpu),
                         [](const auto& info) { return side_name(info.param); });

}  // namespace
}  // namespace basalt::test
