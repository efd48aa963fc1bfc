// Bump and normal mapping (docs/bump-spec.md): the GLSL bump_shading agrees with the CPU
// reference through the PROBE_BUMP probe, and the lean render shader bumps as the full one.
//
// - PROBE_BUMP at every pixel of small scenes, several samples each (more than 1e5 surface
//   hits in all): bumps by fbm, wrinkled, an image map and a constant displacement on spheres
//   (plain and scaled) and on triangle meshes with and without vertex normals (and without uv),
//   diffuse, conductor and coateddiffuse materials, a stochastic mix of a bumped and an
//   unbumped material, normal-mapped planes, spheres and meshes (a PNG normal map written
//   here), a material with both maps (the normal map wins), a displacement whose bumped
//   pair is zero (bump-spec 6.2: the unbumped frame stays), and Shirley's vector turbulence
//   (bump-spec 9) alone, on a bump and on a normal map; and the same under each bump knob
//   (bump-spec 4.5).
// - The hard cases of tests/cpu/bump_test.cpp on the GPU, each a named test: a zero footprint
//   (against the closed form), sphere poles, degenerate uv, back faces, bad normal-map texels,
//   a displacement steep enough to flip the normal (a render: no black pixel, no light lost),
//   and 10^6 synthetic surface points with extreme inputs (PROBE_BUMP's synthetic mode).
//   Both sides must hit the same primitive and agree on whether a bump applied; the shading
//   normal, the pair (dpdu', dpdv') and t1 must agree within a bound derived from the
//   arithmetic: 1e-5 relative for every vector, plus, for the bumped pair, the error of the
//   finite difference (D(cu) - D(c)) / du: two displacement evaluations that agree within
//   `tex_err` (the texture agreement of tests/gpu/texture_probe_test.cpp, 1e-5 absolute plus
//   1e-5 relative for values up to 1, so 4e-5 for the difference) divided by the step du (dv)
//   of bump-spec 4.1 at that hit. The normal's bound follows from the pair's (relative errors
//   of dpdu' and dpdv' over the sine of their angle), t1's from the normal's and dpdu''s.
//   A mismatch is excused only when the query is ill-conditioned: moving the camera by 1 to 16
//   ulps of its position (which moves the hit point by about as much, the precision to which a
//   hit is known) changes the CPU's own answer by half the mismatch (a mesh edge, a mix choice
//   on the edge of its hash quantum, a sphere pole). Excused queries are counted and bounded
//   (< 0.5% of the hits). No output may be NaN or infinite.
// - Renders: the lean render shader bumps and normal-maps bit for bit as the full one, and
//   GPU renders of bumped scenes agree with the CPU reference's as the conformance tests ask.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include <unistd.h>

#include "common/bump_scenes.h"
#include "common/test_util.h"
#include "image/image_io.h"
#include "scene/textures.h"
#include "vk/gpu_renderer.h"

namespace basalt::test {
namespace {

constexpr double kPi = 3.14159265358979323846;

/// Float reinterpretation of an unsigned (probe arguments).
float bits(std::uint32_t u) {
  float f;
  std::memcpy(&f, &u, 4);
  return f;
}


/// A uv sphere as a triangle mesh: centre c, radius r, nu x nv quads, with vertex normals
/// and/or per-vertex uv on request (pbrt's default uv otherwise).
std::string uv_sphere_mesh(glm::vec3 c, float r, int nu, int nv, bool normals, bool uv) {
  std::string P, N, UV, I;
  for (int j = 0; j <= nv; ++j)
    for (int i = 0; i <= nu; ++i) {
      // Pole rows slightly off the axis so that no triangle is degenerate.
      const float th = 3.14159265f * (0.02f + 0.96f * float(j) / float(nv));
      const float ph = 6.2831853f * float(i) / float(nu);
      const glm::vec3 n(std::sin(th) * std::cos(ph), std::cos(th), std::sin(th) * std::sin(ph));
      const glm::vec3 p = c + r * n;
      P += std::to_string(p.x) + " " + std::to_string(p.y) + " " + std::to_string(p.z) + " ";
      N += std::to_string(n.x) + " " + std::to_string(n.y) + " " + std::to_string(n.z) + " ";
      UV += std::to_string(float(i) / float(nu)) + " " + std::to_string(float(j) / float(nv)) + " ";
    }
  for (int j = 0; j < nv; ++j)
    for (int i = 0; i < nu; ++i) {
      const int a = j * (nu + 1) + i, b = a + 1, d = a + nu + 1, e = d + 1;
      I += std::to_string(a) + " " + std::to_string(d) + " " + std::to_string(b) + " " +
           std::to_string(b) + " " + std::to_string(d) + " " + std::to_string(e) + " ";
    }
  std::string s = "Shape \"trianglemesh\" \"integer indices\" [ " + I + "] \"point3 P\" [ " + P + "]";
  if (normals) s += " \"normal N\" [ " + N + "]";
  if (uv) s += " \"point2 uv\" [ " + UV + "]";
  return s + "\n";
}

/// A wavy height field over [-w, w]^2 at height y0 (y = y0 + 0.25 sin(1.3 x) cos(0.9 z)),
/// n x n quads, with its analytic vertex normals on request; uv spans [0, 3] x [0, 2].
std::string wavy_grid(float w, float y0, int n, bool normals) {
  std::string P, N, UV, I;
  for (int j = 0; j <= n; ++j)
    for (int i = 0; i <= n; ++i) {
      const float x = -w + 2.0f * w * float(i) / float(n), z = -w + 2.0f * w * float(j) / float(n);
      const float y = y0 + 0.25f * std::sin(1.3f * x) * std::cos(0.9f * z);
      const glm::vec3 nn = glm::normalize(glm::vec3(-0.25f * 1.3f * std::cos(1.3f * x) * std::cos(0.9f * z),
                                                    1.0f,
                                                    0.25f * 0.9f * std::sin(1.3f * x) * std::sin(0.9f * z)));
      P += std::to_string(x) + " " + std::to_string(y) + " " + std::to_string(z) + " ";
      N += std::to_string(nn.x) + " " + std::to_string(nn.y) + " " + std::to_string(nn.z) + " ";
      UV += std::to_string(3.0f * float(i) / float(n)) + " " + std::to_string(2.0f * float(j) / float(n)) + " ";
    }
  for (int j = 0; j < n; ++j)
    for (int i = 0; i < n; ++i) {
      const int a = j * (n + 1) + i, b = a + 1, d = a + n + 1, e = d + 1;
      I += std::to_string(a) + " " + std::to_string(b) + " " + std::to_string(d) + " " +
           std::to_string(b) + " " + std::to_string(e) + " " + std::to_string(d) + " ";
    }
  std::string s = "Shape \"trianglemesh\" \"integer indices\" [ " + I + "] \"point3 P\" [ " + P +
                  "] \"point2 uv\" [ " + UV + "]";
  if (normals) s += " \"normal N\" [ " + N + "]";
  return s + "\n";
}

/// A back wall (z = 6) and floor (y = -1) without normals, so that every pixel hits.
const char* kRoom = R"(
Shape "trianglemesh" "integer indices" [ 0 1 2 0 2 3 ]
  "point3 P" [ -20 -1 -10  20 -1 -10  20 -1 6  -20 -1 6 ] "point2 uv" [ 0 0 8 0 8 4 0 4 ]
Shape "trianglemesh" "integer indices" [ 0 1 2 0 2 3 ]
  "point3 P" [ -20 -1 6  20 -1 6  20 15 6  -20 15 6 ]
)";

/// One probed scene: its text after kBumpHead, the displacement agreement to allow (tex_err at the
/// top of this file; 0 where no displacement texture is evaluated), and how much of it is bumped.
struct BumpScene {
  const char* name;
  std::string body;
  float tex_err;
  float bumped_min;  // the least fraction of queries that must be bumped
};

/// The scenes of the test; \p dir holds disp.png and normal.png.
std::vector<BumpScene> bump_scenes() {
  std::vector<BumpScene> s;
  // Spheres: each displacement kind and material, a scaled and a flipped sphere.
  s.push_back({"spheres",
               std::string(R"(
Material "diffuse" "rgb reflectance" [ .5 .5 .5 ] "texture displacement" "fbm-s"
)") + kRoom + R"(
AttributeBegin
  Translate -2.2 0.2 0
  Material "diffuse" "rgb reflectance" [ .6 .4 .3 ] "texture displacement" "fbm-s"
  Shape "sphere" "float radius" [ 1.1 ]
AttributeEnd
AttributeBegin
  Translate 0 0.2 0.3
  Material "conductor" "float roughness" [ 0.1 ] "texture displacement" "wr-s"
  Shape "sphere" "float radius" [ 1.0 ]
AttributeEnd
AttributeBegin
  Translate 2.2 0.2 0
  Rotate 40 1 0.3 0
  Material "coateddiffuse" "float displacement" [ 0.05 ]
  Shape "sphere" "float radius" [ 1.0 ]
AttributeEnd
AttributeBegin
  Translate -1 2.2 1.5
  Scale 0.7 0.7 0.7
  Material "diffuse" "texture displacement" "img-s"
  Shape "sphere" "float radius" [ 1.2 ]
AttributeEnd
AttributeBegin
  # Displacement -r on a unit sphere: dpdu' = dpdu - dpdu = 0, no bumped normal (bump-spec 6.2).
  Translate 3.2 2.6 2.5
  Material "diffuse" "float displacement" [ -1 ]
  Shape "sphere" "float radius" [ 1 ]
AttributeEnd
AttributeBegin
  Translate 1.3 2.3 1.5
  ReverseOrientation
  Material "conductor" "float roughness" [ 0.3 ] "texture displacement" "img-t"
  Shape "sphere" "float radius" [ 0.8 ]
AttributeEnd
)",
               4e-5f, 0.9f});
  // Triangle meshes with vertex normals (uv spheres, a wavy grid, one without uv) and
  // without them.
  s.push_back({"meshes",
               std::string(R"(
Material "conductor" "float roughness" [ 0.2 ] "texture displacement" "wr-s"
)") + kRoom + R"(
Material "diffuse" "texture displacement" "fbm-s"
)" + uv_sphere_mesh(glm::vec3(-2.2f, 0.3f, 0.0f), 1.1f, 24, 12, true, true) + R"(
Material "coateddiffuse" "float displacement" [ 0.08 ]
)" + uv_sphere_mesh(glm::vec3(0.0f, 0.3f, 0.4f), 1.0f, 20, 10, true, true) + R"(
Material "conductor" "float roughness" [ 0.15 ] "texture displacement" "img-s"
)" + uv_sphere_mesh(glm::vec3(2.2f, 0.3f, 0.0f), 1.0f, 20, 10, false, true) + R"(
Material "diffuse" "texture displacement" "wr-s"
)" + uv_sphere_mesh(glm::vec3(-1.0f, 2.3f, 1.6f), 0.8f, 16, 8, true, false) + R"(
Material "coateddiffuse" "texture displacement" "img-t"
)" + uv_sphere_mesh(glm::vec3(1.2f, 2.3f, 1.6f), 0.8f, 16, 8, false, false),
               4e-5f, 0.9f});
  // Wavy height fields: with vertex normals (bumped by fbm, an image, a constant) and without.
  s.push_back({"grids",
               std::string(R"(
Material "diffuse" "texture displacement" "img-s"
)") + kRoom + R"(
AttributeBegin
  Translate -2.2 0 0
  Material "diffuse" "texture displacement" "fbm-s"
)" + wavy_grid(1.8f, 0.0f, 10, true) + R"(
AttributeEnd
AttributeBegin
  Translate 2.0 0.2 0
  Material "coateddiffuse" "float displacement" [ 0.3 ]
)" + wavy_grid(1.8f, 0.0f, 10, true) + R"(
AttributeEnd
AttributeBegin
  Translate 0 1.8 1.5
  Rotate -60 1 0 0
  Material "conductor" "float roughness" [ 0.05 ] "texture displacement" "wr-s"
)" + wavy_grid(1.5f, 0.0f, 8, false) + R"(
AttributeEnd
)",
               4e-5f, 0.9f});
  // A stochastic mix of a bumped and an unbumped material (pbrt-v4 syntax), and a mix of two
  // bumped ones.
  s.push_back({"mix",
               std::string(R"(
MakeNamedMaterial "bumped" "string type" "conductor" "float roughness" [ 0.2 ]
    "texture displacement" "fbm-s"
MakeNamedMaterial "plain" "string type" "diffuse" "rgb reflectance" [ .3 .5 .7 ]
MakeNamedMaterial "bumped2" "string type" "coateddiffuse" "texture displacement" "wr-s"
MakeNamedMaterial "m1" "string type" "mix" "string materials" [ "bumped" "plain" ]
    "float amount" [ 0.5 ]
MakeNamedMaterial "m2" "string type" "mix" "string materials" [ "bumped2" "bumped" ]
    "float amount" [ 0.3 ]
MakeNamedMaterial "m3" "string type" "mix" "string materials" [ "m1" "bumped2" ]
    "float amount" [ 0.4 ]
NamedMaterial "m1"
)") + kRoom + R"(
AttributeBegin
  Translate -1.5 0.3 0
  NamedMaterial "m1"
  Shape "sphere" "float radius" [ 1.2 ]
AttributeEnd
AttributeBegin
  Translate 1.5 0.3 0
  NamedMaterial "m3"
  Shape "sphere" "float radius" [ 1.2 ]
AttributeEnd
NamedMaterial "m2"
)" + uv_sphere_mesh(glm::vec3(0.0f, 2.4f, 1.8f), 0.9f, 16, 8, true, true),
               4e-5f, 0.3f});
  // Normal maps: a plane, spheres, meshes with and without vertex normals, and a material
  // with both a normal map and a displacement (the normal map wins).
  s.push_back({"normalmap",
               std::string(R"(
Material "diffuse" "string normalmap" "normal.png"
)") + kRoom + R"(
AttributeBegin
  Translate -2.2 0.2 0
  Material "conductor" "float roughness" [ 0.1 ] "string normalmap" "normal.png"
  Shape "sphere" "float radius" [ 1.1 ]
AttributeEnd
AttributeBegin
  Translate 0 0.2 0.3
  Rotate 70 0 1 0.2
  Material "coateddiffuse" "string normalmap" "normal.png" "texture displacement" "fbm-s"
  Shape "sphere" "float radius" [ 1.0 ]
AttributeEnd
Material "diffuse" "string normalmap" "normal.png"
)" + uv_sphere_mesh(glm::vec3(2.2f, 0.3f, 0.0f), 1.0f, 20, 10, true, true) + R"(
Material "coateddiffuse" "string normalmap" "normal.png"
)" + uv_sphere_mesh(glm::vec3(-1.0f, 2.3f, 1.6f), 0.8f, 16, 8, false, true) + R"(
AttributeBegin
  Translate 1.3 2.2 1.5
  Material "diffuse" "string normalmap" "normal.png"
)" + wavy_grid(0.9f, 0.0f, 6, true) + R"(
AttributeEnd
)",
               0.0f, 0.9f});
  // Shirley's vector turbulence (bump-spec 9): alone on spheres and a mesh with vertex
  // normals, and on top of a bump and of a normal map.
  s.push_back({"vturb", std::string(R"(
Material "diffuse" "rgb reflectance" [ .5 .5 .5 ] "float normalturbulence" [ 0.05 ]
  "float normalturbulencescale" [ 1.5 ]
)") + kRoom + R"(
AttributeBegin
  Translate -2.2 0.2 0
  Material "diffuse" "float normalturbulence" [ 0.24 ] "float normalturbulencescale" [ 8 ]
  Shape "sphere" "float radius" [ 1.1 ]
AttributeEnd
AttributeBegin
  Translate 0 0.2 0.3
  Material "conductor" "float roughness" [ 0.1 ] "texture displacement" "fbm-s"
    "float normalturbulence" [ 0.08 ] "float normalturbulencescale" [ 6 ]
    "integer normalturbulenceoctaves" [ 3 ]
  Shape "sphere" "float radius" [ 1.0 ]
AttributeEnd
AttributeBegin
  Translate 2.2 0.2 0
  Material "coateddiffuse" "string normalmap" "normal.png" "float normalturbulence" [ 0.1 ]
)" + uv_sphere_mesh(glm::vec3(0.0f), 1.0f, 24, 12, true, true) + R"(
AttributeEnd
)",
               4e-5f, 0.9f});
  return s;
}

/// Writes the test images into \p dir: disp.png (a smooth grey height pattern, 20 x 12) and
/// normal.png (an RGB normal map of bumps and ridges, 13 x 9, stored so that its bytes are
/// about (n + 1) / 2 * 255; the PNG writer encodes sRGB and the normal map is read linear).
void write_images(const std::filesystem::path& dir) {
  Image disp{20, 12, {}}, nm{13, 9, {}};
  for (int y = 0; y < disp.height; ++y)
    for (int x = 0; x < disp.width; ++x) {
      const float v = 0.5f + 0.4f * std::sin(0.9f * float(x)) * std::cos(1.3f * float(y));
      disp.pixels.push_back(glm::vec3(v));
    }
  auto srgb_to_linear = [](float v) {
    return v <= 0.04045f ? v / 12.92f : std::pow((v + 0.055f) / 1.055f, 2.4f);
  };
  for (int y = 0; y < nm.height; ++y)
    for (int x = 0; x < nm.width; ++x) {
      glm::vec3 n = glm::normalize(glm::vec3(0.6f * std::sin(1.7f * float(x) + 0.3f * float(y)),
                                             0.5f * std::cos(2.1f * float(y)), 1.0f));
      if ((x + 2 * y) % 11 == 0) n = glm::normalize(glm::vec3(0.9f, -0.7f, 0.15f));  // steep
      const glm::vec3 e = 0.5f * n + glm::vec3(0.5f);
      nm.pixels.push_back(glm::vec3(srgb_to_linear(e.x), srgb_to_linear(e.y), srgb_to_linear(e.z)));
    }
  write_image((dir / "disp.png").string(), disp);
  write_image((dir / "normal.png").string(), nm);
}

/// A scene's tables with its images in a fresh directory.
SceneTables bump_tables(const BumpScene& s) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("basalt-bump-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  write_images(dir);
  SceneTables t =
      build_tables(load_scene_from_string(std::string(kBumpHead) + s.body, "bump.pbrt", dir.string()));
  std::filesystem::remove_all(dir);
  return t;
}

float length3(glm::vec4 v) { return glm::length(glm::vec3(v)); }

/// The per-field bounds of the agreement described at the top of this file, for probe answer
/// \p a (CPU), \p b (GPU) and the CPU footprint answer \p fp of the same query
/// (PROBE_DIFFERENTIALS mode 0): the normal, dpdu', dpdv', t1.
glm::vec4 bounds(const gpu::ProbeOut& a, const gpu::ProbeOut& b, const gpu::ProbeOut& fp,
                 float tex_err, float fixed_step) {
  const float la = std::max(length3(a.f1), length3(b.f1));
  const float lb = std::max(length3(a.f2), length3(b.f2));
  float eu = 1e-6f + 1e-5f * la, ev = 1e-6f + 1e-5f * lb;
  if (a.u.y == 1u) {
    // bump-spec 4.1: the steps of the finite differences at this hit.
    float du = 0.5f * (std::fabs(fp.f0.w) + std::fabs(fp.f1.w));
    float dv = 0.5f * (std::fabs(fp.f2.z) + std::fabs(fp.f2.w));
    if (du == 0.0f) du = 0.0005f;
    if (dv == 0.0f) dv = 0.0005f;
    if (fixed_step > 0.0f) du = dv = fixed_step;  // --bump-step (bump-spec 4.5)
    eu += tex_err / du;
    ev += tex_err / dv;
  }
  // The normal: relative errors of the pair over the sine of its angle.
  const glm::vec3 u(a.f1), v(a.f2);
  const float sine = glm::length(glm::cross(u, v)) / std::max(1e-30f, glm::length(u) * glm::length(v));
  const float en = 1e-5f + (eu / std::max(1e-30f, la) + ev / std::max(1e-30f, lb)) /
                               std::max(1e-30f, sine);
  const float et = en + 1e-5f + eu / std::max(1e-30f, la);
  return glm::vec4(en, eu, ev, et);
}

/// The mismatch of two answers in units of the bounds \p e: the largest field distance over
/// its bound; infinite where the hit primitive or the bump decision differs.
float mismatch(const gpu::ProbeOut& a, const gpu::ProbeOut& b, glm::vec4 e) {
  if (a.u.x != b.u.x || a.u.y != b.u.y) return INFINITY;
  if (a.u.x == gpu::INVALID_INDEX) return 0.0f;
  const float d[4] = {glm::length(glm::vec3(a.f0 - b.f0)), glm::length(glm::vec3(a.f1 - b.f1)),
                      glm::length(glm::vec3(a.f2 - b.f2)), glm::length(glm::vec3(a.f3 - b.f3))};
  float m = 0.0f;
  for (int k = 0; k < 4; ++k) m = std::max(m, d[k] / e[k]);
  return std::isnan(m) ? INFINITY : m;
}

/// True if every output vector of \p o is finite.
bool finite_answer(const gpu::ProbeOut& o) {
  for (const glm::vec4& v : {o.f0, o.f1, o.f2, o.f3})
    if (!std::isfinite(v.x) || !std::isfinite(v.y) || !std::isfinite(v.z)) return false;
  return true;
}

/// \p t with its camera moved by k ulps of its largest coordinate (x +, y -, z +).
SceneTables nudge_camera(const SceneTables& t, int k) {
  SceneTables n = t;
  glm::vec4& o = n.globals.world_from_camera[3];
  const float m = std::max(std::fabs(o.x), std::max(std::fabs(o.y), std::fabs(o.z)));
  const float s = float(k) * (std::nextafter(m, INFINITY) - m);
  o = glm::vec4(o.x + s, o.y - s, o.z + s, o.w);
  return n;
}

/// What compare_bump measured.
struct BumpStats {
  std::size_t queries = 0, hits = 0, bumped = 0, bad = 0, excused = 0, nonfinite = 0;
  double worst = 0.0;  // largest mismatch (in bound units) among the agreeing queries
  double worst_n = 0.0, worst_pair = 0.0;  // largest |n_cpu - n_gpu|, relative pair difference
};

/// PROBE_BUMP at every pixel of \p t, \p spp samples each, on both sides, checked as described
/// at the top of this file (failures are reported; the caller bounds the counts).
BumpStats compare_bump(const char* name, const SceneTables& t, std::uint32_t spp, float tex_err) {
  std::vector<gpu::ProbeIn> q, qf;
  for (std::uint32_t y = 0; y < t.height(); ++y)
    for (std::uint32_t x = 0; x < t.width(); ++x)
      for (std::uint32_t s = 0; s < spp; ++s) {
        gpu::ProbeIn a{};
        a.key = glm::uvec4(gpu::PROBE_BUMP, 0u, x, y);
        a.extra.x = bits(s);
        q.push_back(a);
        a.key.x = gpu::PROBE_DIFFERENTIALS;  // mode 0: the same hit's footprint
        qf.push_back(a);
      }
  const auto cpu = probe(Side::Cpu, t, q);
  const auto gpu = probe(Side::Gpu, t, q);
  const auto fp = probe(Side::Cpu, t, qf);
  float step;
  std::memcpy(&step, &t.globals.texture_opts.z, sizeof(float));
  BumpStats st;
  st.queries = q.size();
  std::vector<std::size_t> suspects;
  std::vector<float> amount;
  for (std::size_t i = 0; i < q.size(); ++i) {
    if (!finite_answer(cpu[i]) || !finite_answer(gpu[i])) {
      if (++st.nonfinite <= 5)
        ADD_FAILURE() << name << " pixel " << q[i].key.z << "," << q[i].key.w
                      << ": non-finite answer";
      continue;
    }
    if (cpu[i].u.x != gpu::INVALID_INDEX) ++st.hits;
    if (cpu[i].u.y == 1u) ++st.bumped;
    const float m = mismatch(cpu[i], gpu[i], bounds(cpu[i], gpu[i], fp[i], tex_err, step));
    if (m > 1.0f) {
      suspects.push_back(i);
      amount.push_back(m);
    } else if (cpu[i].u.x != gpu::INVALID_INDEX) {
      st.worst = std::max(st.worst, double(m));
      st.worst_n = std::max(st.worst_n, double(glm::length(glm::vec3(cpu[i].f0 - gpu[i].f0))));
      st.worst_pair = std::max(
          st.worst_pair, double(std::max(length3(cpu[i].f1 - gpu[i].f1) / length3(cpu[i].f1),
                                         length3(cpu[i].f2 - gpu[i].f2) / length3(cpu[i].f2))));
    }
  }
  if (suspects.empty()) return st;
  // Ill-conditioned queries: the CPU's own answer with the camera 1 to 16 ulps away.
  std::vector<gpu::ProbeIn> sq;
  for (std::size_t i : suspects) sq.push_back(q[i]);
  std::vector<float> spread(suspects.size(), 0.0f);
  for (int k : {1, -1, 2, -2, 4, -4, 8, -8, 16, -16}) {
    const auto near = probe(Side::Cpu, nudge_camera(t, k), sq);
    for (std::size_t j = 0; j < suspects.size(); ++j) {
      const std::size_t i = suspects[j];
      spread[j] = std::max(spread[j],
                           mismatch(cpu[i], near[j], bounds(cpu[i], near[j], fp[i], tex_err, step)));
    }
  }
  for (std::size_t j = 0; j < suspects.size(); ++j) {
    const std::size_t i = suspects[j];
    if (spread[j] >= 0.5f * amount[j]) {
      ++st.excused;
      continue;
    }
    const gpu::ProbeOut &a = cpu[i], &b = gpu[i];
    if (++st.bad <= 10)
      ADD_FAILURE() << name << " pixel " << q[i].key.z << "," << q[i].key.w << " sample "
                    << i % spp << ": mismatch " << amount[j] << " bounds (spread " << spread[j]
                    << "); prim cpu " << a.u.x << " gpu " << b.u.x << ", bumped " << a.u.y
                    << " / " << b.u.y << "; n cpu (" << a.f0.x << ", " << a.f0.y << ", "
                    << a.f0.z << ") gpu (" << b.f0.x << ", " << b.f0.y << ", " << b.f0.z
                    << "); dpdu' cpu (" << a.f1.x << ", " << a.f1.y << ", " << a.f1.z
                    << ") gpu (" << b.f1.x << ", " << b.f1.y << ", " << b.f1.z << "); dpdv' cpu ("
                    << a.f2.x << ", " << a.f2.y << ", " << a.f2.z << ") gpu (" << b.f2.x << ", "
                    << b.f2.y << ", " << b.f2.z << ")";
  }
  return st;
}

TEST(BumpProbe, GpuMatchesCpu) {
  BumpStats all;
  for (const BumpScene& s : bump_scenes()) {
    const SceneTables t = bump_tables(s);
    const bool normal_mapped = std::string(s.name) == "normalmap";
    const bool vturb = std::string(s.name) == "vturb";
    ASSERT_NE(t.features2 & (vturb            ? gpu::FEATURE2_VTURB
                             : normal_mapped ? gpu::FEATURE2_NORMALMAP
                                             : gpu::FEATURE2_BUMP),
              0u)
        << s.name;
    const BumpStats st = compare_bump(s.name, t, 6, s.tex_err);
    std::printf("  %-9s %zu queries, %zu hits, %zu bumped: %zu disagree, %zu excused; agreeing: "
                "worst %.3g of the bound, |dn| <= %.2g, pair <= %.2g relative\n",
                s.name, st.queries, st.hits, st.bumped, st.bad, st.excused, st.worst, st.worst_n,
                st.worst_pair);
    // Most pixels see a bumped or normal-mapped surface (the room is bumped too).
    EXPECT_GT(double(st.bumped), s.bumped_min * double(st.queries)) << s.name;
    if (std::string(s.name) == "mix") {  // the unbumped child is chosen too
      EXPECT_GT(st.hits - st.bumped, st.queries / 10) << s.name;
    }
    if (std::string(s.name) == "spheres") {  // the degenerate bump keeps the unbumped frame
      EXPECT_GT(st.hits - st.bumped, 100u) << s.name;
    }
    all.queries += st.queries;
    all.hits += st.hits;
    all.bumped += st.bumped;
    all.bad += st.bad;
    all.excused += st.excused;
    all.nonfinite += st.nonfinite;
  }
  std::printf("  all: %zu hits, %zu bumped, %zu disagree, %zu excused as ill-conditioned\n",
              all.hits, all.bumped, all.bad, all.excused);
  EXPECT_GE(all.hits, 100000u);
  EXPECT_EQ(all.bad, 0u);
  EXPECT_EQ(all.nonfinite, 0u);
  EXPECT_LT(double(all.excused), 0.005 * double(all.hits));
}


/// The excusal above is not vacuous: moving the camera by 16 ulps changes the CPU's answers.
TEST(BumpProbe, CameraNudgeMovesTheCpuAnswer) {
  const SceneTables t = bump_tables(bump_scenes()[0]);
  std::vector<gpu::ProbeIn> q;
  for (std::uint32_t y = 0; y < t.height(); y += 3)
    for (std::uint32_t x = 0; x < t.width(); x += 3) {
      gpu::ProbeIn a{};
      a.key = glm::uvec4(gpu::PROBE_BUMP, 0u, x, y);
      q.push_back(a);
    }
  const auto a = probe(Side::Cpu, t, q);
  const auto b = probe(Side::Cpu, nudge_camera(t, 16), q);
  std::size_t moved = 0;
  for (std::size_t i = 0; i < q.size(); ++i)
    moved += std::memcmp(&a[i], &b[i], sizeof(gpu::ProbeOut)) != 0 ? 1u : 0u;
  EXPECT_GT(moved, q.size() * 9 / 10);
}

/// A diffuse-only scene bumped by fbm and an image map and normal-mapped (the lean render
/// shader's kind of scene), with \p maps false: the same scene without bump and normal maps.
std::string diffuse_bump_scene(bool maps) {
  std::string s = kBumpHead;
  s += "LightSource \"distant\" \"point3 from\" [ 1 4 -3 ] \"rgb L\" [ 2 2 2 ]\n";
  const std::string fbm = maps ? " \"texture displacement\" \"fbm-s\"" : "";
  const std::string img = maps ? " \"texture displacement\" \"img-s\"" : "";
  const std::string nm = maps ? " \"string normalmap\" \"normal.png\"" : "";
  s += "Material \"diffuse\" \"rgb reflectance\" [ .6 .6 .6 ]" + img + "\n" + kRoom;
  s += "AttributeBegin\nTranslate -1.6 0.3 0\nMaterial \"diffuse\" \"rgb reflectance\" [ .7 .5 .3 ]" +
       fbm + "\nShape \"sphere\" \"float radius\" [ 1.1 ]\nAttributeEnd\n";
  s += "Material \"diffuse\" \"rgb reflectance\" [ .3 .5 .7 ]" + nm + "\n" +
       uv_sphere_mesh(glm::vec3(1.4f, 0.3f, 0.0f), 1.1f, 20, 10, true, true);
  return s;
}

/// Tables of diffuse_bump_scene(maps) with the test images.
SceneTables diffuse_bump_tables(bool maps) {
  const BumpScene s{"diffuse", diffuse_bump_scene(maps).substr(std::string(kBumpHead).size()), 0.0f,
                    0.0f};
  return bump_tables(s);
}

/// 2 samples per pixel of \p t from render shader build \p variant (checked to be \p expected).
std::vector<glm::vec4> render_build(const SceneTables& t, vkx::ShaderVariant variant,
                                    const char* expected) {
  vkx::GpuRenderer gpu(gpu_context(), t, t.features, variant);
  EXPECT_EQ(gpu.variant, expected);
  gpu.render(0, 2);
  return gpu.accum();
}

// The lean render shader (diffuse only) bumps and normal-maps: it picks a bump-mapped diffuse
// scene, renders it bit for bit as the full shader does, and the maps change the image.
TEST(BumpRender, LeanShaderBumpsAsTheFullOne) {
  const SceneTables t = diffuse_bump_tables(true), plain = diffuse_bump_tables(false);
  ASSERT_NE(t.features2 & gpu::FEATURE2_BUMP, 0u);
  ASSERT_NE(t.features2 & gpu::FEATURE2_NORMALMAP, 0u);
  ASSERT_TRUE(vkx::GpuRenderer::lean_suffices(t.features));
  auto& ctx = gpu_context();
  const std::size_t before = ctx.validation_errors();
  const auto lean = render_build(t, vkx::ShaderVariant::automatic, "lean");
  const auto full = render_build(t, vkx::ShaderVariant::full, "full");
  const auto flat = render_build(plain, vkx::ShaderVariant::automatic, "lean");
  EXPECT_EQ(ctx.validation_errors(), before);
  ASSERT_EQ(lean.size(), full.size());
  ASSERT_EQ(lean.size(), flat.size());
  EXPECT_EQ(std::memcmp(lean.data(), full.data(), lean.size() * sizeof(glm::vec4)), 0);
  std::size_t changed = 0;
  for (std::size_t i = 0; i < lean.size(); ++i) changed += lean[i] != flat[i] ? 1u : 0u;
  std::printf("  %zu of %zu pixels changed by the maps\n", changed, lean.size());
  EXPECT_GT(changed, lean.size() / 2);
}

// GPU renders of bump-mapped and normal-mapped scenes (the lean shader's diffuse scene, and
// the probe's spheres and normal-map scenes in the full shader: bumped frames in the local
// frame, the cosines, NEE and the specular differentials) agree with the CPU reference's, as
// the conformance tests ask (99.9% of pixels within 1e-3 relative). Not the mix scene: mixes
// cover every surface there, and a mix choice hashes the hit point, which the renderers
// compute a few ulps apart after a bounce (tests/gpu/conformance_test.cpp); measured at 4 spp:
// 99.51% of its pixels agree without the bumps, 99.15% with them.
TEST(BumpRender, GpuRenderMatchesCpu) {
  std::vector<std::pair<std::string, SceneTables>> scenes;
  scenes.emplace_back("diffuse", diffuse_bump_tables(true));
  for (const BumpScene& s : bump_scenes())
    if (std::string(s.name) == "spheres" || std::string(s.name) == "normalmap")
      scenes.emplace_back(s.name, bump_tables(s));
  for (const auto& [name, t] : scenes) {
    const auto cpu = render(Side::Cpu, t, 4);
    const auto gpu = render(Side::Gpu, t, 4);
    ASSERT_TRUE(all_finite(gpu)) << name;
    ASSERT_GT(mean(cpu), 0.0) << name;
    const double agree = agreeing_fraction(cpu, gpu, 1e-3f);
    std::printf("  %-9s %.4f%% of pixels agree within 1e-3\n", name.c_str(), 100.0 * agree);
    EXPECT_GE(agree, 0.999) << name;
  }
}


// ---- hard cases on the GPU (the CPU twins are the Bump.* tests of tests/cpu/bump_test.cpp) ----

/// Tables of scene text \p body after kBumpHead, with disp.png and normal.png beside it.
SceneTables hard_tables(const std::string& body, const char* name = "hard") {
  return bump_tables(BumpScene{name, body, 0.0f, 0.0f});
}

/// A PROBE_BUMP key.y = 1 query (layout.h): material m at p, uv, ng, ns, shading pair (a, b),
/// footprint (fu, fv), dndu = k a, dndv = k b.
gpu::ProbeIn synthetic(std::uint32_t m, glm::vec3 p, glm::vec2 uv, glm::vec3 ng, glm::vec3 ns,
                       glm::vec3 a, glm::vec3 b, float fu, float fv, float k) {
  gpu::ProbeIn q{};
  q.key = glm::uvec4(gpu::PROBE_BUMP, 1u, m, 0u);
  q.o_tmax = glm::vec4(p, uv.x);
  q.d = glm::vec4(ng, uv.y);
  q.extra = glm::vec4(a, fu);
  q.extra2 = glm::vec4(b, fv);
  q.extra3 = glm::vec4(ns, k);
  return q;
}

/// The GPU's answer is a finite, unit, orthonormal shading normal and frame facing \p ng
/// (within 1e-4), with a finite pair.
::testing::AssertionResult gpu_sane(const gpu::ProbeOut& o, glm::vec3 ng) {
  if (!finite_answer(o)) return ::testing::AssertionFailure() << "non-finite answer";
  const glm::dvec3 n(o.f0), t(o.f3);
  const double e = std::max({std::fabs(glm::length(n) - 1.0), std::fabs(glm::length(t) - 1.0),
                             std::fabs(glm::dot(n, t))});
  if (e > 1e-4) return ::testing::AssertionFailure() << "frame not orthonormal: " << e;
  // Face-forwarded in float: a normal within rounding of ng's horizon may have either sign.
  if (glm::dot(n, glm::dvec3(ng)) < -1e-6) return ::testing::AssertionFailure() << "n below ng";
  return ::testing::AssertionSuccess();
}

/// compare_bump over every pixel of \p t (\p spp samples), asserting no disagreement, no
/// non-finite answer and at least \p min_bumped bumped hits.
void expect_agreement(const char* name, const SceneTables& t, std::uint32_t spp,
                      std::size_t min_bumped, float tex_err = 4e-5f) {
  const BumpStats st = compare_bump(name, t, spp, tex_err);
  std::printf("  %-12s %zu hits, %zu bumped: %zu disagree, %zu excused\n", name, st.hits,
              st.bumped, st.bad, st.excused);
  EXPECT_EQ(st.bad, 0u) << name;
  EXPECT_EQ(st.nonfinite, 0u) << name;
  EXPECT_GE(st.bumped, min_bumped) << name;
  EXPECT_LE(double(st.excused), 0.005 * double(st.hits) + 1.0) << name;
}

/// The smooth stripe d = 0.01 (1 + sin(pi x / 0.25)) (world x) on the quad [-1, 1]^2, z = 0.
const char* kStripe = R"(
Texture "sine" "float" "stripe" "string form" "smooth" "float width" [ 0.25 ]
  "float tex1" [ 0 ] "float tex2" [ 0.02 ]
Material "diffuse" "texture displacement" "sine"
Shape "trianglemesh" "point3 P" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ]
  "integer indices" [ 0 1 2  0 2 3 ] "point2 uv" [ 0 0  1 0  1 1  0 1 ]
)";

// A zero footprint takes pbrt-v4's fallback step 0.0005 on the GPU too: on the stripe plane
// (dpdu = (2, 0, 0)) the bumped normal is within the truncation bound of that step of the
// closed form normalize(-d'(x), 0, 1), at 200 points; and the probe of a scene with Option
// "disabletexturefiltering" (zero footprints everywhere) agrees with the CPU.
TEST(BumpProbe, ZeroDifferentialsUseFallbackStep) {
  const SceneTables t = hard_tables(kStripe);
  std::vector<gpu::ProbeIn> q;
  for (int i = 0; i < 200; ++i) {
    const float x = -0.95f + 1.9f * float(i) / 199.0f;
    q.push_back(synthetic(0u, glm::vec3(x, 0.3f, 0.0f), glm::vec2(0.5f * (x + 1.0f), 0.65f),
                          glm::vec3(0, 0, 1), glm::vec3(0, 0, 1), glm::vec3(2, 0, 0),
                          glm::vec3(0, 2, 0), 0.0f, 0.0f, 0.0f));
  }
  const auto gpu = probe(Side::Gpu, t, q);
  const double amp = 0.01, w = 0.25, h = 2.0 * 0.0005;  // the step in x
  const double bound = 0.5 * h * amp * (kPi / w) * (kPi / w) + 1e-5;
  double worst = 0.0;
  for (std::size_t i = 0; i < q.size(); ++i) {
    ASSERT_TRUE(gpu_sane(gpu[i], glm::vec3(0, 0, 1))) << i;
    ASSERT_EQ(gpu[i].u.y, 1u);
    const double x = q[i].o_tmax.x;
    const double dd = amp * (kPi / w) * std::cos(kPi * x / w);
    const glm::dvec3 exact = glm::normalize(glm::dvec3(-dd, 0.0, 1.0));
    worst = std::max(worst, glm::length(glm::dvec3(gpu[i].f0) - exact));
  }
  std::printf("  zero footprint: GPU normal within %.3g of the closed form (bound %.3g)\n",
              worst, bound);
  EXPECT_LT(worst, bound);
  expect_agreement("no-filter",
                   hard_tables(std::string("Option \"disabletexturefiltering\" true\n") + kStripe),
                   2, 400);
}

// The poles of a sphere (dpdu = 0 there): a camera on the sphere's z axis looks at a pole of
// an fbm-bumped and of a constant-displaced sphere; the GPU agrees with the CPU everywhere and
// stays finite. Synthetic pole points (sdpdu = 0) give a sane frame on both sides, the same one.
TEST(BumpProbe, SpherePoles) {
  const std::string body = R"(
AttributeBegin
  Translate 0 0.4 3
  Material "diffuse" "texture displacement" "fbm-s"
  Shape "sphere" "float radius" [ 1.2 ]
AttributeEnd
)";
  SceneTables t = hard_tables(body);
  // Look down the z axis at the pole (0, 0.4, 1.8).
  t.globals.world_from_camera = glm::mat4(1.0f);
  t.globals.world_from_camera[3] = glm::vec4(0.0f, 0.4f, -3.0f, 1.0f);
  t.globals.camera_from_world = glm::inverse(t.globals.world_from_camera);
  expect_agreement("pole", t, 4, 1500);
  const SceneTables tc = hard_tables(R"(Material "diffuse" "float displacement" [ 0.2 ]
Shape "sphere")");
  for (const SceneTables* tt : {static_cast<const SceneTables*>(&t), &tc}) {
    std::vector<gpu::ProbeIn> q;
    for (int i = 0; i < 64; ++i) {
      const float a = 0.1f * float(i);
      const glm::vec3 ng(0, 0, 1);
      q.push_back(synthetic(0u, glm::vec3(0.0f, 0.4f, 1.8f), glm::vec2(0.01f * float(i), 0.0f),
                            ng, ng, glm::vec3(0.0f), glm::vec3(std::cos(a), std::sin(a), 0.0f),
                            1e-3f, 1e-3f, 1.0f / 1.2f));
    }
    const auto gpu = probe(Side::Gpu, *tt, q), cpu = probe(Side::Cpu, *tt, q);
    for (std::size_t i = 0; i < q.size(); ++i) {
      ASSERT_TRUE(gpu_sane(gpu[i], glm::vec3(0, 0, 1))) << i;
      ASSERT_EQ(gpu[i].u.y, cpu[i].u.y) << i;
      ASSERT_LT(glm::length(glm::vec3(gpu[i].f0 - cpu[i].f0)), 1e-4f) << i;
    }
  }
}

// A mesh triangle with degenerate uv (every vertex at the same uv: zero uv area, dpdu = dpdv
// = 0, the Duff pair stands in): bumped by a 3D texture (fbm, which still varies) and by an
// image (constant over the triangle); finite and the same on both sides.
TEST(BumpProbe, DegenerateUvTriangle) {
  const std::string body = R"(
AttributeBegin
  Material "diffuse" "texture displacement" "fbm-s"
  Shape "trianglemesh" "point3 P" [ -3 -1 0  0 -1 0  -1.5 2 0.5 ] "integer indices" [ 0 1 2 ]
    "point2 uv" [ 0.3 0.3  0.3 0.3  0.3 0.3 ]
  Material "diffuse" "texture displacement" "img-s"
  Shape "trianglemesh" "point3 P" [ 0 -1 0  3 -1 0  1.5 2 0.5 ] "integer indices" [ 0 1 2 ]
    "point2 uv" [ 0.6 0.2  0.6 0.2  0.6 0.2 ] "normal N" [ 0 0 -1  0.2 0 -1  0 0.2 -1 ]
AttributeEnd
)";
  expect_agreement("degenerate-uv", hard_tables(body), 4, 1000);
}

// A back-facing hit: the camera sees the back of a bumped quad (and of a normal-mapped one);
// the bumped normal is face-forwarded to the geometric normal on the GPU as on the CPU, and a
// synthetic back face (ng = -z with a +z pair) comes out facing -z.
TEST(BumpProbe, BackFacingHit) {
  const std::string body = R"(
AttributeBegin
  Material "diffuse" "texture displacement" "wr-s"
  Shape "trianglemesh" "point3 P" [ -3 -1 1  0 -1 1  0 2 1  -3 2 1 ]
    "integer indices" [ 0 2 1  0 3 2 ] "point2 uv" [ 0 0  1 0  1 1  0 1 ]
  Material "diffuse" "string normalmap" "normal.png"
  Shape "trianglemesh" "point3 P" [ 0 -1 1  3 -1 1  3 2 1  0 2 1 ]
    "integer indices" [ 0 2 1  0 3 2 ] "point2 uv" [ 0 0  1 0  1 1  0 1 ]
AttributeEnd
)";
  expect_agreement("back-facing", hard_tables(body), 4, 1500);
  const SceneTables t = hard_tables(kStripe);
  std::vector<gpu::ProbeIn> q;
  for (int i = 0; i < 32; ++i)
    q.push_back(synthetic(0u, glm::vec3(-0.9f + 0.05f * float(i), 0.2f, 0.0f),
                          glm::vec2(0.05f + 0.025f * float(i), 0.6f), glm::vec3(0, 0, -1),
                          glm::vec3(0, 0, -1), glm::vec3(2, 0, 0), glm::vec3(0, 2, 0), 1e-3f,
                          1e-3f, 0.0f));
  const auto gpu = probe(Side::Gpu, t, q);
  for (std::size_t i = 0; i < q.size(); ++i) {
    ASSERT_TRUE(gpu_sane(gpu[i], glm::vec3(0, 0, -1))) << i;
    ASSERT_LT(gpu[i].f0.z, -0.9f) << i;
  }
}

// Normal-map texels of (0, 0, 0) (nt = normalize(-1, -1, -1), below the surface), of
// (0.5, 0.5, 0.5) (nt = 0: no normal map there) and (0.5, 0.5, 0) (straight down), written as
// an EXR (read linear, exact): the GPU keeps the frame where nt = 0, gives a finite normal
// facing ng elsewhere, and agrees with the CPU.
TEST(BumpProbe, NormalMapTexelZeroOrBelowSurface) {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / ("basalt-nm-" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  write_images(dir);  // kBumpHead's textures
  Image im{3, 1, {glm::vec3(0.0f), glm::vec3(0.5f), glm::vec3(0.5f, 0.5f, 0.0f)}};
  write_image((dir / "bad.exr").string(), im);
  const SceneTables t = build_tables(load_scene_from_string(std::string(kBumpHead) + R"(
Material "diffuse" "string normalmap" "bad.exr"
Shape "trianglemesh" "point3 P" [ -3 -1 1  3 -1 1  3 2 1  -3 2 1 ]
  "integer indices" [ 0 1 2  0 2 3 ] "point2 uv" [ 0 0  1 0  1 1  0 1 ]
)", "nm.pbrt", dir.string()));
  std::filesystem::remove_all(dir);
  std::vector<gpu::ProbeIn> q;
  for (int texel = 0; texel < 3; ++texel)
    for (int i = 0; i < 16; ++i) {
      const glm::vec3 ng(0, 0, -1);
      q.push_back(synthetic(0u, glm::vec3(0.0f, 0.0f, 1.0f),
                            glm::vec2((float(texel) + 0.5f) / 3.0f, 0.03f * float(i)), ng, ng,
                            glm::vec3(6, 0, 0), glm::vec3(0, 3, 0), 1e-3f, 1e-3f, 0.0f));
    }
  const auto gpu = probe(Side::Gpu, t, q), cpu = probe(Side::Cpu, t, q);
  for (std::size_t i = 0; i < q.size(); ++i) {
    const int texel = int(i / 16);
    ASSERT_TRUE(gpu_sane(gpu[i], glm::vec3(0, 0, -1))) << i;
    ASSERT_EQ(gpu[i].u.y, texel == 1 ? 0u : 1u) << "texel " << texel;
    ASSERT_EQ(gpu[i].u.y, cpu[i].u.y) << i;
    ASSERT_LT(glm::length(glm::vec3(gpu[i].f0 - cpu[i].f0)), 1e-5f) << i;
  }
  expect_agreement("bad-texels", t, 2, 500);
}

// Displacement large enough to flip the bumped normal below the geometric horizon (seed 000
// Fig. 9.2): the GPU render of the steep stripe bump has no black pixel and the mean of the
// unbumped plane (within 4 standard errors: no light leak, no energy lost), as on the CPU.
TEST(BumpRender, LargeDisplacementFlip) {
  auto scene = steep_scene;
  const std::uint32_t spp = 64;
  const auto ib = render(Side::Gpu, tables_from_string(scene(true)), spp);
  const auto iu = render(Side::Gpu, tables_from_string(scene(false)), spp);
  ASSERT_TRUE(all_finite(ib));
  double mb, seb, mu, seu;
  mean_and_se(ib, mb, seb);
  mean_and_se(iu, mu, seu);
  int black = 0;
  for (const glm::vec3& p : ib) black += !(p.x > 0.0f);
  const double bound = 4.0 * std::sqrt(seb * seb + seu * seu);
  std::printf("  steep bump on the GPU: mean %.5f, unbumped %.5f, bound %.5f, black pixels %d\n",
              mb, mu, bound, black);
  EXPECT_LT(std::fabs(mb - mu), bound);
  EXPECT_EQ(black, 0);
}

// With --shading-normal-rule pbrt-v4 (materials-spec 1.2) the GPU renders the steep bump as
// the CPU reference does (99.9% of pixels within 1e-3, as the conformance tests ask).
TEST(BumpRender, PbrtV4RuleMatchesCpu) {
  SceneTables t = tables_from_string(steep_scene(true));
  apply_shading_rule(t, true);
  const auto cpu = render(Side::Cpu, t, 4);
  const auto gpu = render(Side::Gpu, t, 4);
  ASSERT_TRUE(all_finite(gpu));
  const double agree = agreeing_fraction(cpu, gpu, 1e-3f);
  std::printf("  pbrt-v4 rule: %.4f%% of pixels agree within 1e-3\n", 100.0 * agree);
  EXPECT_GE(agree, 0.999);
}

// 10^6 bump, normal-map and vector-turbulence evaluations on the GPU with extreme inputs
// (points up to 1e3 and 1e30, footprints and pairs from 1e-30 to 1e30 or zero, parallel pairs,
// normals across the horizon, non-finite and huge normal-map texels): every answer is finite
// and, where the frame changed, unit, orthonormal and facing ng; the same for the CPU's answers
// to the same queries.
TEST(BumpProbe, RandomExtremeInputs) {
  SceneTables t = hard_tables(R"(
Material "diffuse" "texture displacement" "fbm-s"
Shape "sphere"
Material "diffuse" "string normalmap" "normal.png"
Shape "sphere"
Material "diffuse" "float normalturbulence" [ 0.3 ] "float normalturbulencescale" [ 4 ]
  "float displacement" [ 0.1 ]
Shape "sphere"
)");
  std::vector<std::uint32_t> mats;
  for (std::uint32_t m = 0; m < t.materials.size(); ++m)
    if (t.materials[m].flags & (gpu::MATFLAG_BUMP | gpu::MATFLAG_NORMALMAP | gpu::MATFLAG_VTURB))
      mats.push_back(m);
  ASSERT_EQ(mats.size(), 3u);
  std::mt19937 rng(2026u);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  // The normal map's texels: 2% NaN, 2% infinite, 4% huge or tiny, the rest in [0, 1].
  for (gpu::MipLevel& ml : t.mip_levels)
    for (std::uint32_t i = 0; i < ml.width * ml.height * ml.channels; ++i) {
      const float r = U(rng);
      t.texels[ml.offset + i] = r < 0.02f ? NAN : r < 0.04f ? INFINITY : r < 0.08f ? 1e30f : U(rng);
    }
  auto unit = [&] {
    for (;;) {
      const glm::vec3 v(2.0f * U(rng) - 1.0f, 2.0f * U(rng) - 1.0f, 2.0f * U(rng) - 1.0f);
      const float l2 = glm::dot(v, v);
      if (l2 > 1e-4f && l2 <= 1.0f) return v / std::sqrt(l2);
    }
  };
  auto mag = [&] {  // 0, or 10^[-30, 30] with a random sign
    if (U(rng) < 0.1f) return 0.0f;
    const float m = std::pow(10.0f, 60.0f * U(rng) - 30.0f);
    return U(rng) < 0.5f ? -m : m;
  };
  std::size_t changed = 0, total = 0, same = 0, cpu_bad = 0;
  for (int batch = 0; batch < 5; ++batch) {
    std::vector<gpu::ProbeIn> q;
    std::vector<glm::vec3> ngs;
    for (int i = 0; i < 200000; ++i) {
      glm::vec3 ng = unit();
      const glm::vec3 ns = U(rng) < 0.5f ? ng : unit();
      if (glm::dot(ns, ng) < 0.0f) ng = -ng;
      const glm::vec3 p(1e3f * (2.0f * U(rng) - 1.0f), 1e3f * U(rng),
                        U(rng) < 0.01f ? mag() : 0.0f);
      const glm::vec2 uv(U(rng) < 0.05f ? mag() : U(rng), U(rng));
      const glm::vec3 adir = unit();
      const glm::vec3 a = adir * std::fabs(mag());
      const float r = U(rng);
      const glm::vec3 b = r < 0.05f ? adir * mag() : r < 0.1f ? ns * mag() : unit() * std::fabs(mag());
      q.push_back(synthetic(mats[std::size_t(i) % 3u], p, uv, ng, ns, a, b, mag(), mag(),
                            U(rng) < 0.3f ? 0.0f : mag()));
      ngs.push_back(ng);
    }
    const auto gpu = probe(Side::Gpu, t, q);
    const auto cpu = probe(Side::Cpu, t, q);
    for (std::size_t i = 0; i < q.size(); ++i) {
      ++total;
      same += gpu[i].u.y == cpu[i].u.y ? 1u : 0u;
      if (!finite_answer(cpu[i]) || (cpu[i].u.y == 1u && !gpu_sane(cpu[i], ngs[i]))) {
        if (++cpu_bad <= 5) ADD_FAILURE() << "CPU answer to query " << i << " not sane";
      }
      if (!finite_answer(gpu[i])) {
        ADD_FAILURE() << "non-finite answer at " << i;
        continue;
      }
      if (gpu[i].u.y != 1u) continue;
      ++changed;
      const ::testing::AssertionResult ok = gpu_sane(gpu[i], ngs[i]);
      if (!ok) ADD_FAILURE() << "query " << i << ": " << ok.message();
    }
  }
  std::printf("  10^6 extreme inputs: %zu changed the GPU's frame; the CPU decided the same for "
              "%zu; all finite and sane\n", changed, same);
  EXPECT_EQ(total, 1000000u);
  EXPECT_EQ(cpu_bad, 0u);
  EXPECT_GT(changed, total / 10);
}

// The bump knobs of bump-spec 4.5 (central differences, no d dn/du term, a fixed step) act
// the same on both sides: the probe of the spheres scene agrees under each.
TEST(BumpProbe, KnobsGpuMatchesCpu) {
  struct Knob {
    const char* name;
    bool central, dndu;
    float step;
  };
  for (const Knob k : {Knob{"central", true, true, 0.0f}, Knob{"no-dndu", false, false, 0.0f},
                       Knob{"step-1e-3", false, true, 1e-3f}, Knob{"all", true, false, 2e-3f}}) {
    SceneTables t = bump_tables(bump_scenes()[0]);
    apply_bump_knobs(t, k.central, k.dndu, k.step);
    expect_agreement(k.name, t, 1, 1500);
  }
}

}  // namespace
}  // namespace basalt::test
