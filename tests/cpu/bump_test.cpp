// Bump and normal mapping of the CPU reference (docs/bump-spec.md 3-6): bump_map against the
// closed-form normal of analytic displacements (a sine on a plane, a constant on a sphere) and
// its first-order convergence, normal_map against the frame it defines, the hard cases (zero
// footprints, poles, degenerate uv, back faces, texels at or below the surface, flips below
// the geometric horizon, random extreme inputs) and the integration into the path tracer
// (bsdf_at applies it; scenes without bumps are untouched).
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cfloat>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "common/scratch_dir.h"
#include "cpu/bsdf.h"
#include "cpu/bump.h"
#include "cpu/camera.h"
#include "cpu/intersect.h"
#include "cpu/probe.h"
#include "cpu/surface.h"
#include "common/bump_scenes.h"
#include "common/test_util.h"
#include "image/image_io.h"
#include "cpu/noise.h"
#include "scene/scene.h"
#include "scene/textures.h"

namespace basalt::test {
namespace {

using namespace basalt::cpu;
namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;

bool finite3(glm::vec3 v) { return std::isfinite(v.x) && std::isfinite(v.y) && std::isfinite(v.z); }

/// |a - b| in double.
double dist(glm::vec3 a, glm::dvec3 b) { return glm::length(glm::dvec3(a) - b); }

/// The shading normal and frame of sp are finite, unit and orthonormal within \p tol, the
/// frame's normal is the shading normal, and it faces the geometric normal.
::testing::AssertionResult sane_shading(const SurfacePoint& sp, double tol = 1e-5) {
  const Frame& f = sp.frame;
  if (!finite3(sp.g.ns) || !finite3(f.t1) || !finite3(f.t2) || !finite3(f.n))
    return ::testing::AssertionFailure() << "non-finite normal or frame";
  const glm::dvec3 a(f.t1), b(f.t2), n(f.n);
  const double e = std::max({std::fabs(glm::length(a) - 1.0), std::fabs(glm::length(b) - 1.0),
                             std::fabs(glm::length(n) - 1.0), std::fabs(glm::dot(a, b)),
                             std::fabs(glm::dot(a, n)), std::fabs(glm::dot(b, n))});
  if (e > tol) return ::testing::AssertionFailure() << "frame not orthonormal: " << e;
  if (f.n != sp.g.ns) return ::testing::AssertionFailure() << "frame normal != shading normal";
  if (glm::dot(sp.g.ns, sp.g.ng) < 0.0f)
    return ::testing::AssertionFailure() << "shading normal not face-forwarded to ng";
  return ::testing::AssertionSuccess();
}

/// A hit on the plane z = 0 of side L at uv (p = L uv), ns = ng = +z, dpdu = (L, 0, 0),
/// dpdv = (0, L, 0), every (u, v) differential \p h.
SurfacePoint plane_point(glm::vec2 uv, float L, float h) {
  SurfacePoint sp;
  sp.g.p = glm::vec3(L * uv.x, L * uv.y, 0.0f);
  sp.g.ng = sp.g.ns = glm::vec3(0.0f, 0.0f, 1.0f);
  sp.g.dpdu = glm::vec3(L, 0.0f, 0.0f);
  sp.g.dpdv = glm::vec3(0.0f, L, 0.0f);
  sp.g.uv = uv;
  sp.frame = shading_frame(sp.g.ns, sp.g.dpdu);
  sp.tex.p = sp.g.p;
  sp.tex.n = sp.g.ng;
  sp.tex.uv = uv;
  sp.tex.dudx = sp.tex.dudy = sp.tex.dvdx = sp.tex.dvdy = h;
  sp.sdpdu = sp.g.dpdu;
  sp.sdpdv = sp.g.dpdv;
  return sp;
}

/// The exact normal of the plane of plane_point displaced by d with partial derivatives
/// (d_u, d_v): cross(dpdu + d_u n, dpdv + d_v n) ~ (-d_u / L, -d_v / L, 1).
glm::dvec3 plane_normal(double d_u, double d_v, double L) {
  return glm::normalize(glm::dvec3(-d_u / L, -d_v / L, 1.0));
}

/// The first camera hit of pixel (x, y), sample s, as the path tracer builds it (camera
/// differentials scaled by Globals.min_dir_dx.w); false on a miss.
bool camera_hit(const SceneTables& t, std::uint32_t x, std::uint32_t y, std::uint32_t s,
                SurfacePoint& sp, glm::vec3& d, std::uint32_t* prim = nullptr) {
  const CameraRay c = camera_ray_differential(t, x, y, s);
  RayDifferential diff{c.rx_o, c.rx_d, c.ry_o, c.ry_d};
  scale_differentials(diff, c.o, c.d, t.globals.min_dir_dx.w);
  const Ray ray{c.o, c.d, FLT_MAX};
  const Hit h = intersect_closest(t, ray);
  if (!h.valid()) return false;
  sp = surface_point(t, ray, h, &diff);
  d = c.d;
  if (prim) *prim = h.prim;
  return true;
}

/// A per-process scratch directory for image files.
fs::path temp_dir() { return basalt::test::scratch_dir("bump"); }

/// Writes a w x h EXR of constant linear rgb \p c into temp_dir(); returns its file name.
std::string write_constant_exr(const std::string& name, glm::vec3 c, int w = 4, int h = 4) {
  Image im;
  im.width = w;
  im.height = h;
  im.pixels.assign(std::size_t(w) * std::size_t(h), c);
  write_image((temp_dir() / name).string(), im);
  return name;
}

/// Tables of a scene text whose relative files are in temp_dir().
SceneTables tables_in_temp(const std::string& text) {
  return build_tables(load_scene_from_string(text, "t.pbrt", temp_dir().string()));
}

/// The error bound of the bumped normal of the stripe displacement d = amp (1 + sin(pi x / w))
/// on the quad [-1, 1]^2 (dpdu = (2, 0, 0)) at hit sp: the forward difference's truncation
/// h/2 max|d_xx| with h = 2 du the step in x, plus 1e-5 for float rounding (the stripe's sine is
/// good to an ulp or two of its value, over the step).
double sine_bound(const SurfacePoint& sp, double amp, double w) {
  double du = 0.5 * (std::fabs(double(sp.tex.dudx)) + std::fabs(double(sp.tex.dudy)));
  if (du == 0.0) du = 0.0005;
  return 0.5 * (2.0 * du) * amp * (kPi / w) * (kPi / w) + 1e-5;
}

// ---- closed forms ----------------------------------------------------------------------------

/// The quad [-1, 1]^2 at z = 0 (uv [0, 1]^2) bumped by d(x) = 0.01 (1 + sin(pi x / 0.25))
/// (Shirley's smooth stripe), seen from (0, 0, cam_z) at 256 x 256 and 64 spp.
SceneTables sine_plane_tables(float cam_z) {
  return tables_from_string("LookAt 0 0 " + std::to_string(cam_z) + R"(  0 0 0  0 1 0
Camera "perspective" "float fov" [ 30 ]
Film "rgb" "integer xresolution" [ 256 ] "integer yresolution" [ 256 ]
Sampler "independent" "integer pixelsamples" [ 64 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Texture "sine" "float" "stripe" "string form" "smooth" "float width" [ 0.25 ]
  "float tex1" [ 0 ] "float tex2" [ 0.02 ]
Material "diffuse" "texture displacement" "sine"
Shape "trianglemesh" "point3 P" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ]
  "integer indices" [ 0 1 2  0 2 3 ] "point2 uv" [ 0 0  1 0  1 1  0 1 ]
)");
}

// d(u, v) = A sin(2 pi f u) on a plane: the bumped normal is normalize(ns - d'(u) dpdu / |dpdu|^2)
// (cross(dpdu + d' n, dpdv) for orthogonal dpdu, dpdv of length L). bump_map's forward
// difference of step h is off by h/2 d''(u) in the slope, so with h = 2^-13 (exact in uv at
// u = k / 64), A = 0.05, f = 2, L = 2 the normal is within h/2 A (2 pi f)^2 / L = 2.4e-4.
// Then the same through the parser, the tables, bsdf_at and PROBE_BUMP: a quad bumped by
// Shirley's "stripe" texture of form "smooth" (d = 0.01 (1 + sin(pi x / 0.25)) in world x).
TEST(Bump, SinePlaneMatchesClosedForm) {
  const float L = 2.0f, h = 0x1p-13f;
  const double A = 0.05, f = 2.0;
  const Displacement D = [&](const TextureContext& c) {
    return float(A * std::sin(2.0 * kPi * f * double(c.uv.x)));
  };
  double worst = 0.0, worst_t = 0.0;
  for (int k = 0; k < 64; ++k) {
    const float u = float(k) / 64.0f;
    SurfacePoint sp = plane_point(glm::vec2(u, 0.3f), L, h);
    glm::vec3 dpdu, dpdv;
    bump_map(D, sp, dpdu, dpdv);
    ASSERT_TRUE(set_shading_geometry(sp, dpdu, dpdv)) << "u = " << u;
    ASSERT_TRUE(sane_shading(sp)) << "u = " << u;
    const double d_u = A * 2.0 * kPi * f * std::cos(2.0 * kPi * f * double(u));
    worst = std::max(worst, dist(sp.g.ns, plane_normal(d_u, 0.0, L)));
    // The frame's s is dpdu' = (L, 0, d_u) normalised.
    worst_t = std::max(worst_t, dist(sp.frame.t1, glm::normalize(glm::dvec3(L, 0.0, d_u))));
  }
  // Truncation h/2 max|d''| / L, plus the rounding of D to float (half an ulp of A = 0.05 at
  // each of two values, over the step h, over L).
  const double bound = 0.5 * double(h) * A * (2.0 * kPi * f) * (2.0 * kPi * f) / L +
                       double(0x1p-28f) / double(h) / L;
  std::printf("[ bump ] sine plane (direct): max normal error %.3g, max s error %.3g, "
              "bound %.3g\n", worst, worst_t, bound);
  EXPECT_LT(worst, 1e-3);
  EXPECT_LT(worst, bound);
  EXPECT_LT(worst_t, 1e-3);

  // Through the scene: d(x) = 0.01 (1 + sin(pi x / w)), w = 0.25, on the quad [-1, 1]^2 at
  // z = 0 with uv [0, 1]^2 (dpdu = (2, 0, 0)): n = normalize(ns - d_x x). The step is the
  // footprint's (about 2e-4 in u at 256 x 256 and the 64-spp differential scale), so the
  // truncation error is below 2 du / 2 * 0.01 (pi / w)^2 = 3.2e-4.
  const SceneTables t = sine_plane_tables(3.0f);
  ASSERT_TRUE(t.features2 & gpu::FEATURE2_BUMP);
  const double w = 0.25, amp = 0.01;
  std::vector<gpu::ProbeIn> q;
  std::vector<SurfacePoint> bumped;
  std::vector<glm::vec3> dpdus;
  double worst_scene = 0.0, max_du = 0.0;
  int n = 0;
  for (std::uint32_t y = 0; y < 256; y += 8)
    for (std::uint32_t x = 0; x < 256; x += 8) {
      SurfacePoint sp;
      glm::vec3 d;
      if (!camera_hit(t, x, y, 0u, sp, d)) continue;
      const SurfacePoint before = sp;
      max_du = std::max(max_du, 0.5 * (std::fabs(sp.tex.dudx) + std::fabs(sp.tex.dudy)));
      glm::vec3 du_b, dv_b;
      bump_map(t, t.materials[sp.material], sp, du_b, dv_b);
      (void)bsdf_at(t, sp.material, sp, -d);  // applies the bump to sp
      ASSERT_TRUE(sane_shading(sp)) << x << "," << y;
      const double px = double(before.g.p.x);
      const double d_x = amp * (kPi / w) * std::cos(kPi * px / w);
      const glm::dvec3 expect = glm::normalize(glm::dvec3(before.g.ns) - d_x * glm::dvec3(1, 0, 0));
      const double err = dist(sp.g.ns, expect);
      worst_scene = std::max(worst_scene, err);
      EXPECT_LT(err, sine_bound(before, amp, w)) << x << "," << y;
      ++n;
      gpu::ProbeIn pi{};
      pi.key = glm::uvec4(gpu::PROBE_BUMP, 0u, x, y);
      pi.extra.x = std::bit_cast<float>(0u);
      q.push_back(pi);
      bumped.push_back(sp);
      dpdus.push_back(du_b);
    }
  std::printf("[ bump ] sine plane (scene, %d hits): max normal error %.3g (max du %.3g)\n", n,
              worst_scene, max_du);
  EXPECT_GT(n, 900);
  EXPECT_LT(worst_scene, 1e-3);
  // PROBE_BUMP reports exactly what bsdf_at left in the surface point.
  const std::vector<gpu::ProbeOut> out = cpu::probe(t, q);
  for (std::size_t i = 0; i < out.size(); ++i) {
    EXPECT_EQ(out[i].u.y, 1u);
    EXPECT_EQ(glm::vec3(out[i].f0), bumped[i].g.ns);
    EXPECT_EQ(glm::vec3(out[i].f1), dpdus[i]);
    EXPECT_EQ(glm::vec3(out[i].f3), bumped[i].frame.t1);
  }
}

// A constant displacement d on a sphere of radius r is the sphere of radius r + d: the d dn/du
// term (dndu = dpdu / r) gives dpdu' = dpdu (1 + d / r), dpdv' = dpdv (1 + d / r), so the normal
// and frame keep their direction. With an object-to-world scale s, textures-spec 3.2's
// dndu = dpdu / (s r) (pbrt-v4's normal transform) makes the factor 1 + d / (s r). Checked
// over every camera hit (equator facing the camera, poles at the silhouette) within 1e-5.
TEST(Bump, ConstantDisplacementOnSphereIsLargerSphere) {
  // Without the d dn/du term (--bump-dndu off, bump-spec 4.5) the same displacement changes
  // nothing: factor 1, the pair bit for bit, the normal and frame within rounding (1e-6).
  struct Case {
    const char* shape;
    float factor;
    bool dndu;
  };
  const Case cases[] = {
      {"Shape \"sphere\" \"float radius\" [ 1 ]", 1.0f + 0.1f / 1.0f, true},
      {"Scale 2 2 2 Shape \"sphere\" \"float radius\" [ 0.5 ]", 1.0f + 0.1f / (2.0f * 1.0f), true},
      {"ReverseOrientation Shape \"sphere\" \"float radius\" [ 1 ]", 1.0f + 0.1f / 1.0f, true},
      {"Scale 2 2 2 Shape \"sphere\" \"float radius\" [ 0.5 ]", 1.0f, false},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.shape);
    SceneTables t = tables_from_string(std::string(R"(
LookAt -5 0 0  0 0 0  0 1 0
Camera "perspective" "float fov" [ 30 ]
Film "rgb" "integer xresolution" [ 64 ] "integer yresolution" [ 64 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Material "diffuse" "float displacement" [ 0.1 ]
)") + c.shape + "\n");
    if (!c.dndu) apply_bump_knobs(t, false, false, 0.0f);
    const double tol = c.dndu ? 1e-5 : 1e-6;
    double worst_pair = 0.0, worst_n = 0.0, worst_f = 0.0;
    int n = 0;
    for (std::uint32_t y = 0; y < 64; ++y)
      for (std::uint32_t x = 0; x < 64; ++x) {
        SurfacePoint sp;
        glm::vec3 d;
        if (!camera_hit(t, x, y, 0u, sp, d)) continue;
        const SurfacePoint before = sp;
        glm::vec3 du, dv;
        bump_map(t, t.materials[sp.material], sp, du, dv);
        const glm::vec3 eu = before.sdpdu * c.factor, ev = before.sdpdv * c.factor;
        if (!c.dndu) {
          ASSERT_EQ(du, before.sdpdu);
          ASSERT_EQ(dv, before.sdpdv);
        }
        worst_pair = std::max({worst_pair, double(glm::length(du - eu) / glm::length(eu)),
                               double(glm::length(dv - ev) / glm::length(ev))});
        (void)bsdf_at(t, sp.material, sp, -d);
        ASSERT_TRUE(sane_shading(sp));
        worst_n = std::max(worst_n, dist(sp.g.ns, glm::dvec3(before.g.ns)));
        worst_f = std::max({worst_f, dist(sp.frame.t1, glm::dvec3(before.frame.t1)),
                            dist(sp.frame.t2, glm::dvec3(before.frame.t2))});
        ++n;
      }
    std::printf("[ bump ] constant displacement (%s, dn/du %s, %d hits): dpdu/dpdv rel. error %.3g, "
                "normal %.3g, frame %.3g\n", c.shape, c.dndu ? "on" : "off", n, worst_pair, worst_n, worst_f);
    EXPECT_GT(n, 500);
    EXPECT_LT(worst_pair, tol);
    EXPECT_LT(worst_n, tol);
    EXPECT_LT(worst_f, tol);
  }
}

/// Least-squares slope of ly against lx.
double fitted_slope(const std::vector<double>& lx, const std::vector<double>& ly) {
  double mx = 0, my = 0;
  for (std::size_t i = 0; i < lx.size(); ++i) mx += lx[i], my += ly[i];
  mx /= double(lx.size());
  my /= double(ly.size());
  double sxy = 0, sxx = 0;
  for (std::size_t i = 0; i < lx.size(); ++i) {
    sxy += (lx[i] - mx) * (ly[i] - my);
    sxx += (lx[i] - mx) * (lx[i] - mx);
  }
  return sxy / sxx;
}

// Forward differences (pbrt-v4 BumpMap) converge at first order: over a decade of steps
// (1e-2 to 1e-3, 9 steps) the error of the bumped normal against the analytic one of a smooth
// displacement, fitted as log(error) = a + k log(step), has slope k in [0.8, 1.2]. At three
// points where d'' is not zero in either direction. Central differences (bump-spec 4.5)
// converge at second order: slope in [1.8, 2.2] over steps 1e-1 to 1e-2 (below that the fp32
// rounding of the displacement values, ~3e-9 / h, meets the h^2 truncation).
TEST(Bump, Convergence) {
  const double A = 0.05, B = 0.03;
  const Displacement D = [&](const TextureContext& c) {
    return float(A * std::sin(2.0 * kPi * double(c.uv.x)) +
                 B * std::sin(2.0 * kPi * double(c.uv.y) + 0.4));
  };
  const glm::vec2 points[] = {{0.1f, 0.2f}, {0.35f, 0.6f}, {0.7f, 0.85f}};
  for (const bool central : {false, true}) {
    BumpKnobs knobs;
    knobs.central = central;
    const double h0 = central ? 1e-1 : 1e-2;
    for (const glm::vec2 uv : points) {
      const double d_u = A * 2.0 * kPi * std::cos(2.0 * kPi * double(uv.x));
      const double d_v = B * 2.0 * kPi * std::cos(2.0 * kPi * double(uv.y) + 0.4);
      const glm::dvec3 exact = plane_normal(d_u, d_v, 1.0);
      std::vector<double> lx, ly;
      for (int i = 0; i <= 8; ++i) {
        const float h = float(h0 * std::pow(10.0, -double(i) / 8.0));
        SurfacePoint sp = plane_point(uv, 1.0f, h);
        glm::vec3 dpdu, dpdv;
        bump_map(D, sp, dpdu, dpdv, knobs);
        ASSERT_TRUE(set_shading_geometry(sp, dpdu, dpdv));
        lx.push_back(std::log(double(h)));
        ly.push_back(std::log(dist(sp.g.ns, exact)));
      }
      const double slope = fitted_slope(lx, ly);
      std::printf("[ bump ] %s-difference convergence at (%.2f, %.2f): slope %.4f, error %.3g "
                  "at %.0e, %.3g at %.0e\n", central ? "central" : "forward", uv.x, uv.y, slope,
                  std::exp(ly.front()), h0, std::exp(ly.back()), h0 / 10.0);
      const double order = central ? 2.0 : 1.0;
      EXPECT_GE(slope, order - 0.2);
      EXPECT_LE(slope, order + 0.2);
    }
  }
}

// The knobs of bump-spec 4.5 reach the displacement as written: a fixed step h replaces the
// footprint (and the fallback) in both parameters; central differences evaluate D at the hit
// and at p +- h dpdu, uv +- (h, 0) and the same in v, and take (D+ - D-) / 2h; the default
// evaluates the hit and the two forward contexts.
TEST(Bump, KnobsShiftTheContextsAsSpecified) {
  SurfacePoint sp = plane_point(glm::vec2(0.25f, 0.5f), 2.0f, 0.01f);
  std::vector<TextureContext> seen;
  const Displacement D = [&](const TextureContext& c) {
    seen.push_back(c);
    return 0.5f * c.uv.x + 0.25f * c.uv.y;  // linear: every scheme is exact
  };
  struct Case {
    bool central;
    float fixed;
  };
  for (const Case k : {Case{false, 0.0f}, Case{true, 0.0f}, Case{false, 0.125f},
                       Case{true, 0.0625f}}) {
    SCOPED_TRACE(testing::Message() << "central " << k.central << " fixed " << k.fixed);
    BumpKnobs knobs;
    knobs.central = k.central;
    knobs.fixed_step = k.fixed;
    seen.clear();
    glm::vec3 dpdu, dpdv;
    bump_map(D, sp, dpdu, dpdv, knobs);
    const float h = k.fixed > 0.0f ? k.fixed : 0.01f;  // footprint: 0.5 (|0.01| + |0.01|)
    ASSERT_EQ(seen.size(), k.central ? 5u : 3u);
    std::vector<glm::vec2> uvs;
    for (const TextureContext& c : seen) uvs.push_back(c.uv);
    auto has = [&](glm::vec2 uv, glm::vec3 p) {
      for (const TextureContext& c : seen)
        if (c.uv == uv && c.p == p) return true;
      return false;
    };
    EXPECT_TRUE(has(sp.tex.uv, sp.tex.p));
    EXPECT_TRUE(has(sp.tex.uv + glm::vec2(h, 0.0f), sp.tex.p + h * sp.sdpdu));
    EXPECT_TRUE(has(sp.tex.uv + glm::vec2(0.0f, h), sp.tex.p + h * sp.sdpdv));
    if (k.central) {
      EXPECT_TRUE(has(sp.tex.uv - glm::vec2(h, 0.0f), sp.tex.p - h * sp.sdpdu));
      EXPECT_TRUE(has(sp.tex.uv - glm::vec2(0.0f, h), sp.tex.p - h * sp.sdpdv));
    }
    // d_u = 0.5, d_v = 0.25 exactly for a linear D (h a power of two keeps uv exact).
    EXPECT_NEAR(dpdu.z, 0.5f, 1e-5f);
    EXPECT_NEAR(dpdv.z, 0.25f, 1e-5f);
  }
  // The knobs travel in Globals.texture_opts (apply_bump_knobs) and bump_knobs reads them back.
  SceneTables t = sine_plane_tables(3.0f);
  EXPECT_EQ(bump_knobs(t.globals).central, false);
  EXPECT_EQ(bump_knobs(t.globals).dndu, true);
  EXPECT_EQ(bump_knobs(t.globals).fixed_step, 0.0f);
  apply_bump_knobs(t, true, false, 1e-3f);
  EXPECT_EQ(bump_knobs(t.globals).central, true);
  EXPECT_EQ(bump_knobs(t.globals).dndu, false);
  EXPECT_EQ(bump_knobs(t.globals).fixed_step, 1e-3f);
}

// ---- hard cases ------------------------------------------------------------------------------

// A zero footprint (Option "disabletexturefiltering", or a context with zero dudx ... dvdy)
// makes the step 0.0005 in u and in v (pbrt-v4 BumpMap): the shifted contexts are exactly
// p + 0.0005 sdpdu, uv + (0.0005, 0) and p + 0.0005 sdpdv, uv + (0, 0.0005). Through the
// scene (stripe bump of SinePlaneMatchesClosedForm, filtering disabled) the normal stays within
// the truncation bound of that step, h/2 |d_xx| with h = 2 * 0.0005 in x.
TEST(Bump, ZeroDifferentialsUseFallbackStep) {
  SurfacePoint sp = plane_point(glm::vec2(0.3f, 0.6f), 2.0f, 0.0f);
  std::vector<TextureContext> seen;
  const Displacement D = [&](const TextureContext& c) {
    seen.push_back(c);
    return 0.01f * c.uv.x + 0.02f * c.uv.y;
  };
  glm::vec3 dpdu, dpdv;
  bump_map(D, sp, dpdu, dpdv);
  ASSERT_EQ(seen.size(), 3u);
  EXPECT_EQ(seen[0].p, sp.tex.p + 0.0005f * sp.sdpdu);
  EXPECT_EQ(seen[0].uv, sp.tex.uv + glm::vec2(0.0005f, 0.0f));
  EXPECT_EQ(seen[1].p, sp.tex.p + 0.0005f * sp.sdpdv);
  EXPECT_EQ(seen[1].uv, sp.tex.uv + glm::vec2(0.0f, 0.0005f));
  EXPECT_EQ(seen[2].p, sp.tex.p);
  EXPECT_EQ(seen[2].uv, sp.tex.uv);
  for (const TextureContext& c : seen) {  // nothing else of the context moves
    EXPECT_EQ(c.n, sp.tex.n);
    EXPECT_EQ(c.dudx, 0.0f);
    EXPECT_EQ(c.dvdy, 0.0f);
  }
  ASSERT_TRUE(set_shading_geometry(sp, dpdu, dpdv));
  EXPECT_TRUE(sane_shading(sp));
  EXPECT_LT(dist(sp.g.ns, plane_normal(0.01, 0.02, 2.0)), 1e-4);

  const SceneTables t = tables_from_string(R"(
Option "disabletexturefiltering" true
LookAt 0 0 3  0 0 0  0 1 0
Camera "perspective" "float fov" [ 30 ]
Film "rgb" "integer xresolution" [ 64 ] "integer yresolution" [ 64 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Texture "sine" "float" "stripe" "string form" "smooth" "float width" [ 0.25 ]
  "float tex1" [ 0 ] "float tex2" [ 0.02 ]
Material "diffuse" "texture displacement" "sine"
Shape "trianglemesh" "point3 P" [ -1 -1 0  1 -1 0  1 1 0  -1 1 0 ]
  "integer indices" [ 0 1 2  0 2 3 ] "point2 uv" [ 0 0  1 0  1 1  0 1 ]
)");
  const double w = 0.25, amp = 0.01;
  SurfacePoint zero;  // a zero footprint: the fallback step
  const double bound = sine_bound(zero, amp, w);
  double worst = 0.0;
  int n = 0;
  for (std::uint32_t y = 0; y < 64; ++y)
    for (std::uint32_t x = 0; x < 64; ++x) {
      SurfacePoint s;
      glm::vec3 d;
      if (!camera_hit(t, x, y, 0u, s, d)) continue;
      ASSERT_EQ(s.tex.dudx, 0.0f);
      ASSERT_EQ(s.tex.dudy, 0.0f);
      ASSERT_EQ(s.tex.dvdx, 0.0f);
      ASSERT_EQ(s.tex.dvdy, 0.0f);
      const SurfacePoint before = s;
      (void)bsdf_at(t, s.material, s, -d);
      ASSERT_TRUE(sane_shading(s));
      const double d_x = amp * (kPi / w) * std::cos(kPi * double(before.g.p.x) / w);
      worst = std::max(worst, dist(s.g.ns, glm::normalize(glm::dvec3(before.g.ns) -
                                                           d_x * glm::dvec3(1, 0, 0))));
      ++n;
    }
  std::printf("[ bump ] zero footprint (%d hits): max normal error %.3g, bound %.3g\n", n, worst,
              bound);
  EXPECT_GT(n, 3000);
  EXPECT_LT(worst, bound);
}

/// Scene text of a unit sphere at the origin (pole axis z) with material \p material.
std::string sphere_scene(const std::string& material) {
  return R"(
LookAt 0 -6 0.5  0 0 0  0 0 1
Camera "perspective" "float fov" [ 30 ]
Film "rgb" "integer xresolution" [ 16 ] "integer yresolution" [ 16 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Texture "fbm" "float" "fbm" "integer octaves" [ 6 ]
Texture "bumps" "float" "scale" "texture tex" "fbm" "float scale" [ 0.05 ]
Texture "uvbumps" "float" "bilerp" "float v00" [ 0 ] "float v01" [ 0.3 ] "float v10" [ -0.2 ]
  "float v11" [ 0.1 ]
)" + material + R"(
Shape "sphere" "float radius" [ 1 ]
)";
}

// At the poles dpdu is zero (dpdv is not): the shading pair is the Duff pair of ng (bump-spec
// 3), dndu is zero. Rays exactly at both poles and 1e-7 .. 1e-2 off them, with a constant, a
// solid (fbm) and a uv (bilerp) displacement: finite, orthonormal and face-forwarded.
TEST(Bump, SpherePoles) {
  const char* materials[] = {
      R"(Material "diffuse" "float displacement" [ 0.1 ])",
      R"(Material "diffuse" "texture displacement" "bumps")",
      R"(Material "diffuse" "texture displacement" "uvbumps")",
  };
  for (const char* m : materials) {
    SCOPED_TRACE(m);
    const SceneTables t = tables_from_string(sphere_scene(m));
    int exact_poles = 0, changed = 0;
    for (float zs : {1.0f, -1.0f})
      for (float off : {0.0f, 1e-7f, 1e-5f, 1e-3f, 1e-2f})
        for (int k = 0; k < 4; ++k) {
          const glm::vec3 o(off * float(k % 2), off * float(k / 2), 5.0f * zs);
          const Ray ray{o, glm::vec3(0.0f, 0.0f, -zs), FLT_MAX};
          const Hit h = intersect_closest(t, ray);
          ASSERT_TRUE(h.valid());
          SurfacePoint sp = surface_point(t, ray, h);
          if (sp.g.dpdu == glm::vec3(0.0f)) ++exact_poles;
          ASSERT_TRUE(finite3(sp.sdpdu) && finite3(sp.sdpdv));
          ASSERT_NE(glm::cross(sp.sdpdu, sp.sdpdv), glm::vec3(0.0f));
          glm::vec3 du, dv;
          if (bump_shading(t, t.materials[sp.material], sp, &du, &dv)) ++changed;
          EXPECT_TRUE(sane_shading(sp)) << "off " << off << " k " << k << " z " << zs;
          EXPECT_TRUE(finite3(du) && finite3(dv));
        }
    EXPECT_GE(exact_poles, 2);  // the rays at off = 0 hit the poles exactly
    EXPECT_EQ(changed, 40);
  }
}

// A triangle whose uv are all equal (det = 0): dpdu = 0 and the pair is the Duff pair of ng;
// with vertex normals too (pair from ns, dndu from the Duff pair of dn). Solid and uv
// displacements, camera hits over the whole triangle: finite, orthonormal, face-forwarded.
TEST(Bump, DegenerateUvTriangle) {
  const char* shapes[] = {
      R"(Shape "trianglemesh" "point3 P" [ -1 -1 0  1 -1 0  0 1 0 ] "integer indices" [ 0 1 2 ]
  "point2 uv" [ 0.5 0.5  0.5 0.5  0.5 0.5 ])",
      R"(Shape "trianglemesh" "point3 P" [ -1 -1 0  1 -1 0  0 1 0 ] "integer indices" [ 0 1 2 ]
  "point2 uv" [ 0.5 0.5  0.5 0.5  0.5 0.5 ] "normal N" [ -0.3 0 1  0.3 0 1  0 0.3 1 ])",
      R"(Shape "trianglemesh" "point3 P" [ -1 -1 0  1 -1 0  0 1 0 ] "integer indices" [ 0 1 2 ]
  "point2 uv" [ 0 0  1 1  2 2 ] "normal N" [ -0.3 0 1  0.3 0 1  0 0.3 1 ])",
  };
  for (const char* shape : shapes)
    for (const char* disp : {"bumps", "uvbumps"}) {
      SCOPED_TRACE(std::string(shape) + " " + disp);
      const SceneTables t = tables_from_string(std::string(R"(
LookAt 0 0 3  0 0 0  0 1 0
Camera "perspective" "float fov" [ 50 ]
Film "rgb" "integer xresolution" [ 32 ] "integer yresolution" [ 32 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Texture "fbm" "float" "fbm" "integer octaves" [ 6 ]
Texture "bumps" "float" "scale" "texture tex" "fbm" "float scale" [ 0.05 ]
Texture "uvbumps" "float" "bilerp" "float v00" [ 0 ] "float v01" [ 0.3 ] "float v10" [ -0.2 ]
  "float v11" [ 0.1 ]
Material "diffuse" "texture displacement" ")") + disp + "\"\n" + shape + "\n");
      int n = 0, changed = 0;
      for (std::uint32_t y = 0; y < 32; ++y)
        for (std::uint32_t x = 0; x < 32; ++x) {
          SurfacePoint sp;
          glm::vec3 d;
          if (!camera_hit(t, x, y, 0u, sp, d)) continue;
          ++n;
          EXPECT_EQ(sp.g.dpdu, glm::vec3(0.0f));  // degenerate uv map
          glm::vec3 du, dv;
          if (bump_shading(t, t.materials[sp.material], sp, &du, &dv)) ++changed;
          ASSERT_TRUE(sane_shading(sp)) << x << "," << y;
          ASSERT_TRUE(finite3(du) && finite3(dv));
        }
      EXPECT_GT(n, 100);
      EXPECT_EQ(changed, n);
    }
}

// A quad seen from behind (its ng, +z, faces away from the camera; triangles without vertex
// normals keep their orientation, path-spec 4) and a sphere seen from inside: the bumped normal
// is face-forwarded to ng, not to the viewer, and on the quad matches the closed form of
// SinePlaneMatchesClosedForm (the bump does not depend on the side it is seen from).
TEST(Bump, BackFacingHit) {
  const SceneTables t = sine_plane_tables(-3.0f);
  const double w = 0.25, amp = 0.01;
  double worst = 0.0;
  int n = 0;
  for (std::uint32_t y = 0; y < 256; y += 4)
    for (std::uint32_t x = 0; x < 256; x += 4) {
      SurfacePoint sp;
      glm::vec3 d;
      if (!camera_hit(t, x, y, 0u, sp, d)) continue;
      ASSERT_GT(glm::dot(d, sp.g.ng), 0.0f);  // seen from behind
      ASSERT_EQ(sp.g.ng, glm::vec3(0, 0, 1));
      const SurfacePoint before = sp;
      (void)bsdf_at(t, sp.material, sp, -d);
      ASSERT_TRUE(sane_shading(sp));
      const double d_x = amp * (kPi / w) * std::cos(kPi * double(before.g.p.x) / w);
      const double err =
          dist(sp.g.ns, glm::normalize(glm::dvec3(0, 0, 1) - d_x * glm::dvec3(1, 0, 0)));
      worst = std::max(worst, err);
      EXPECT_LT(err, sine_bound(before, amp, w)) << x << "," << y;
      ++n;
    }
  std::printf("[ bump ] back-facing quad (%d hits): max normal error %.3g\n", n, worst);
  EXPECT_GT(n, 3000);
  EXPECT_LT(worst, 1e-3);

  // Inside a sphere (the camera at its centre): ng points outwards, away from the viewer.
  const SceneTables s = tables_from_string(R"(
LookAt 0 0 0  0 0 1  0 1 0
Camera "perspective" "float fov" [ 60 ]
Film "rgb" "integer xresolution" [ 32 ] "integer yresolution" [ 32 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Texture "fbm" "float" "fbm" "integer octaves" [ 6 ]
Texture "bumps" "float" "scale" "texture tex" "fbm" "float scale" [ 0.2 ]
Material "diffuse" "texture displacement" "bumps"
Shape "sphere" "float radius" [ 2 ]
)");
  int inside = 0;
  for (std::uint32_t y = 0; y < 32; ++y)
    for (std::uint32_t x = 0; x < 32; ++x) {
      SurfacePoint sp;
      glm::vec3 d;
      ASSERT_TRUE(camera_hit(s, x, y, 0u, sp, d));
      ASSERT_GT(glm::dot(d, sp.g.ng), 0.0f);
      EXPECT_TRUE(bump_shading(s, s.materials[sp.material], sp));
      ASSERT_TRUE(sane_shading(sp)) << x << "," << y;
      ++inside;
    }
  EXPECT_EQ(inside, 32 * 32);
}

/// Tables holding one normal-mapped diffuse material and a 1 x 1 rgb MipLevel of texel \p c.
SceneTables one_texel_normal_map(glm::vec3 c) {
  SceneTables t;
  gpu::Material m{};
  m.type = gpu::MATERIAL_DIFFUSE;
  for (auto& tx : m.texture) tx = glm::uvec4(gpu::INVALID_INDEX);
  m.value[gpu::SLOT_DIFFUSE_REFLECTANCE] = glm::vec4(0.5f);
  m.flags = gpu::MATFLAG_NORMALMAP;
  m.value[gpu::SLOT_NORMALMAP] = glm::vec4(0.0f);
  t.materials.push_back(m);
  t.mip_levels.push_back(gpu::MipLevel{0u, 1u, 1u, 3u});
  t.texels = {c.x, c.y, c.z};
  return t;
}

// Normal-map texels that give no usable normal: (0.5, 0.5, 0.5) (nt = 0), non-finite texels and
// a zero sdpdu leave the surface point exactly as it was (bump-spec 5 steps 2, 3). A texel
// straight below the surface, (0.5, 0.5, 0), gives -ns, face-forwarded to +ng; one tilted
// below, nt = (0.6, 0, -0.8), gives -nt = (-0.6, 0, 0.8) in the (dpdu, n) frame.
TEST(Bump, NormalMapTexelZeroOrBelowSurface) {
  auto same = [](const SurfacePoint& a, const SurfacePoint& b) {
    return a.g.ns == b.g.ns && a.frame.t1 == b.frame.t1 && a.frame.t2 == b.frame.t2 &&
           a.frame.n == b.frame.n;
  };
  for (glm::vec3 c : {glm::vec3(0.5f), glm::vec3(NAN, 0.5f, 1.0f), glm::vec3(INFINITY, 0, 0),
                      glm::vec3(1e30f, 1e30f, 1e30f)}) {
    const SceneTables t = one_texel_normal_map(c);
    SurfacePoint sp = plane_point(glm::vec2(0.3f, 0.4f), 1.0f, 0.01f);
    const SurfacePoint before = sp;
    glm::vec3 du, dv;
    EXPECT_FALSE(bump_shading(t, t.materials[0], sp, &du, &dv)) << c.x;
    EXPECT_TRUE(same(sp, before));
    EXPECT_EQ(du, before.sdpdu);  // the unbumped pair, as PROBE_BUMP reports it
    EXPECT_EQ(dv, before.sdpdv);
  }
  {  // a zero shading pair: no frame to map into
    const SceneTables t = one_texel_normal_map(glm::vec3(0.7f, 0.5f, 0.9f));
    SurfacePoint sp = plane_point(glm::vec2(0.3f, 0.4f), 1.0f, 0.01f);
    sp.sdpdu = glm::vec3(0.0f);
    const SurfacePoint before = sp;
    EXPECT_FALSE(bump_shading(t, t.materials[0], sp));
    EXPECT_TRUE(same(sp, before));
  }
  struct Below {
    glm::vec3 texel;
    glm::dvec3 expect;
  };
  const Below below[] = {{glm::vec3(0.5f, 0.5f, 0.0f), glm::dvec3(0, 0, 1)},
                         {glm::vec3(0.8f, 0.5f, 0.1f), glm::dvec3(-0.6, 0, 0.8)}};
  for (const Below& b : below) {
    const SceneTables t = one_texel_normal_map(b.texel);
    SurfacePoint sp = plane_point(glm::vec2(0.3f, 0.4f), 1.0f, 0.01f);
    // Before face-forwarding the mapped normal points below: n' . ng < 0.
    glm::vec3 du, dv;
    ASSERT_TRUE(normal_map(t, 0u, sp, du, dv));
    EXPECT_LT(glm::dot(glm::cross(du, dv), sp.g.ng), 0.0f);
    ASSERT_TRUE(bump_shading(t, t.materials[0], sp));
    EXPECT_TRUE(sane_shading(sp));
    EXPECT_LT(dist(sp.g.ns, b.expect), 1e-6) << b.texel.x << " " << b.texel.z;
  }
}

// A steep bump on a quad whose vertex normals lean 26.6 degrees off ng: its shading tangent
// plane dips below ng's horizon, and where the slope is steep enough the bumped normal
// n' = normalize(cross(dpdu', dpdv')) points below it; bump_shading face-forwards it (n' . ng
// >= 0). Rendered under a uniform white sky, a diffuse surface alone reflects R L whatever its
// shading normal (the light-leak rule integrates |n' . wi| over ng's hemisphere, which is pi
// for every unit n'): so the bumped image's mean must equal the unbumped one's within the
// Monte Carlo noise (4 standard errors of the difference), with no NaN and no black pixel.
TEST(Bump, LargeDisplacementFlip) {
  auto scene = steep_scene;
  const SceneTables tb = tables_from_string(scene(true));
  const SceneTables tu = tables_from_string(scene(false));
  int flipped = 0, n = 0;
  for (std::uint32_t y = 0; y < 48; ++y)
    for (std::uint32_t x = 0; x < 48; ++x)
      for (std::uint32_t s = 0; s < 4; ++s) {
        SurfacePoint sp;
        glm::vec3 d;
        ASSERT_TRUE(camera_hit(tb, x, y, s, sp, d));
        glm::vec3 du, dv;
        bump_map(tb, tb.materials[sp.material], sp, du, dv);
        if (glm::dot(glm::cross(du, dv), sp.g.ng) < 0.0f) ++flipped;
        ASSERT_TRUE(bump_shading(tb, tb.materials[sp.material], sp));
        ASSERT_TRUE(sane_shading(sp)) << x << "," << y;
        ++n;
      }
  std::printf("[ bump ] steep bump: %d of %d hits flipped below ng's horizon\n", flipped, n);
  EXPECT_GT(flipped, n / 20);

  const std::uint32_t spp = 64;
  const std::vector<glm::vec3> ib = render(Side::Cpu, tb, spp);
  const std::vector<glm::vec3> iu = render(Side::Cpu, tu, spp);
  ASSERT_TRUE(all_finite(ib));
  ASSERT_TRUE(all_finite(iu));
  double mb, seb, mu, seu;
  mean_and_se(ib, mb, seb);
  mean_and_se(iu, mu, seu);
  const double bound = 4.0 * std::sqrt(seb * seb + seu * seu);
  int black = 0;
  for (const glm::vec3& p : ib)
    if (!(p.x > 0.0f)) ++black;
  std::printf("[ bump ] steep bump render: mean %.5f (se %.5f), unbumped %.5f (se %.5f), "
              "|difference| %.5f, bound %.5f, black pixels %d\n", mb, seb, mu, seu,
              std::fabs(mb - mu), bound, black);
  EXPECT_LT(std::fabs(mb - mu), bound);
  EXPECT_LT(std::fabs(mu - 0.5), 4.0 * seu + 1e-3);
  EXPECT_EQ(black, 0);
}

// --shading-normal-rule pbrt-v4 (materials-spec 1.2) turns basalt's light-leak rule off, and the
// two artefacts of Fig. 9.2 come back on the steep bump: (a) a distant light below the plane
// leaks through it where the bumped normals turn towards the light (basalt's rule: every pixel
// exactly black); (b) a grazing light above it leaves black spots where the bumped normals turn
// away from it (the mean falls below basalt's by more than 4 standard errors). (Under a
// uniform sky the two rules agree on the mean: what the spots lose, the leak gains.) The
// unbumped plane, whose tilted vertex normals never put the light and the viewer on different
// sides, renders the same under both rules, bit for bit.
TEST(Bump, PbrtV4RuleLeaksAndLosesLightWhereTheNormalFlips) {
  auto lit = [](bool bumped, const std::string& light) {
    std::string text = steep_scene(bumped);
    const std::string sky = "LightSource \"infinite\" \"rgb L\" [ 1 1 1 ]";
    text.replace(text.find(sky), sky.size(), light);
    return tables_from_string(text);
  };
  // (a) pbrt's default "to" is (0, 0, 1): the light arrives from (1, 0, -0.4), below the plane.
  const std::string below = "LightSource \"distant\" \"point3 from\" [ 1 0 0.6 ] \"rgb L\" [ 3 3 3 ]";
  const std::string above =
      "LightSource \"distant\" \"point3 from\" [ 1 0 0.6 ] \"point3 to\" [ 0 0 0 ] \"rgb L\" [ 3 3 3 ]";
  const std::uint32_t spp = 64;
  SceneTables leak = lit(true, below), leak_pbrt = lit(true, below);
  apply_shading_rule(leak_pbrt, true);
  const std::vector<glm::vec3> lb = render(Side::Cpu, leak, spp);
  const std::vector<glm::vec3> lp = render(Side::Cpu, leak_pbrt, spp);
  ASSERT_TRUE(all_finite(lb) && all_finite(lp));
  std::printf("[ bump ] light below the plane: mean %.5f with basalt's rule, %.5f leaks with "
              "pbrt-v4's\n", mean(lb), mean(lp));
  EXPECT_EQ(mean(lb), 0.0);
  EXPECT_GT(mean(lp), 0.01);
  SceneTables tb = lit(true, above), tb_pbrt = lit(true, above), tu = lit(false, above),
              tu_pbrt = lit(false, above);
  apply_shading_rule(tb_pbrt, true);
  apply_shading_rule(tu_pbrt, true);
  const std::vector<glm::vec3> ib = render(Side::Cpu, tb, spp);
  const std::vector<glm::vec3> ip = render(Side::Cpu, tb_pbrt, spp);
  ASSERT_TRUE(all_finite(ib) && all_finite(ip));
  double mb, seb, mp, sep;
  mean_and_se(ib, mb, seb);
  mean_and_se(ip, mp, sep);
  const double bound = 4.0 * std::sqrt(seb * seb + sep * sep);
  std::printf("[ bump ] grazing light above: mean %.5f with basalt's rule, %.5f with pbrt-v4's "
              "(%.1f%% darker, bound %.5f)\n", mb, mp, 100.0 * (1.0 - mp / mb), bound);
  EXPECT_LT(mp, mb - bound);
  const std::vector<glm::vec3> iu = render(Side::Cpu, tu, 8);
  const std::vector<glm::vec3> iu_pbrt = render(Side::Cpu, tu_pbrt, 8);
  EXPECT_EQ(std::memcmp(iu.data(), iu_pbrt.data(), iu.size() * sizeof(glm::vec3)), 0);
}

// 10^6 bump evaluations with random extreme inputs (displacements, footprints, shading pairs and
// normal derivatives from 1e-30 to 1e30 and 0, parallel pairs, non-finite displacements) and
// 2 10^5 normal-map evaluations on random texels (some huge or non-finite): bump_shading either
// leaves the point exactly as it was or gives a finite, unit, face-forwarded normal, an
// orthonormal frame and finite dpdu', dpdv'.
TEST(Bump, RandomExtremeInputs) {
  std::mt19937 rng(12345u);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
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
  auto vec = [&] { return unit() * std::fabs(mag()); };
  // A normal-mapped material over an 8 x 8 level of random texels.
  SceneTables t;
  {
    gpu::Material m{};
    m.type = gpu::MATERIAL_DIFFUSE;
    for (auto& tx : m.texture) tx = glm::uvec4(gpu::INVALID_INDEX);
    m.flags = gpu::MATFLAG_NORMALMAP;
    t.materials.push_back(m);
    t.mip_levels.push_back(gpu::MipLevel{0u, 8u, 8u, 3u});
    for (int i = 0; i < 8 * 8 * 3; ++i) {
      const float r = U(rng);
      t.texels.push_back(r < 0.02f ? NAN : r < 0.04f ? INFINITY : r < 0.08f ? mag() : U(rng));
    }
  }
  auto check = [&](const SurfacePoint& before, const SurfacePoint& sp, bool changed,
                   glm::vec3 du, glm::vec3 dv, long i) {
    if (!changed) {
      if (!(sp.g.ns == before.g.ns && sp.frame.t1 == before.frame.t1 &&
            sp.frame.t2 == before.frame.t2))
        ADD_FAILURE() << "unchanged point modified at " << i;
      return;
    }
    const ::testing::AssertionResult ok = sane_shading(sp, 1e-4);
    if (!ok || !finite3(du) || !finite3(dv)) ADD_FAILURE() << "evaluation " << i << ": " << ok.message();
  };
  long changed_bump = 0, changed_nm = 0, failures_before = 0;
  for (long i = 0; i < 1000000; ++i) {
    SurfacePoint sp;
    sp.g.ng = unit();
    sp.g.ns = U(rng) < 0.5f ? sp.g.ng : unit();
    if (glm::dot(sp.g.ns, sp.g.ng) < 0.0f) sp.g.ng = -sp.g.ng;
    sp.g.p = glm::vec3(1e3f * (2.0f * U(rng) - 1.0f), 1e3f * U(rng), U(rng) < 0.01f ? mag() : 0.0f);
    sp.tex.p = sp.g.p;
    sp.tex.n = sp.g.ng;
    sp.tex.uv = glm::vec2(U(rng) < 0.05f ? mag() : U(rng), U(rng));
    sp.tex.dudx = mag();
    sp.tex.dudy = mag();
    sp.tex.dvdx = mag();
    sp.tex.dvdy = mag();
    const float r = U(rng);
    sp.sdpdu = vec();
    sp.sdpdv = r < 0.05f ? sp.sdpdu * mag() : r < 0.1f ? sp.g.ns * mag() : vec();
    sp.g.dpdu = sp.sdpdu;
    sp.g.dndu = U(rng) < 0.3f ? glm::vec3(0.0f) : vec();
    sp.g.dndv = U(rng) < 0.3f ? glm::vec3(0.0f) : vec();
    sp.frame = shading_frame(sp.g.ns, sp.g.dpdu);
    const SurfacePoint before = sp;
    const float amp = mag(), freq = std::fabs(mag());
    const bool nan_disp = U(rng) < 0.01f;
    const Displacement D = [&](const TextureContext& c) {
      if (nan_disp) return NAN;
      return amp * std::sin(freq * c.uv.x + 0.37f * c.uv.y + 1e-3f * c.p.x);
    };
    glm::vec3 du, dv;
    bump_map(D, sp, du, dv);
    const bool ch = set_shading_geometry(sp, du, dv);
    changed_bump += ch;
    check(before, sp, ch, du, dv, i);
    if (i % 5 == 0) {
      SurfacePoint s2 = before;
      glm::vec3 nu, nv;
      const bool c2 = bump_shading(t, t.materials[0], s2, &nu, &nv);
      changed_nm += c2;
      check(before, s2, c2, nu, nv, i);
    }
    if (::testing::Test::HasFailure() && ++failures_before > 20) break;
  }
  std::printf("[ bump ] random extremes: %ld of 1e6 bumps and %ld of 2e5 normal maps changed "
              "the frame\n", changed_bump, changed_nm);
  EXPECT_GT(changed_bump, 100000);
  EXPECT_GT(changed_nm, 10000);
}

// ---- normal maps and integration ----------------------------------------------------------

// A constant normal map (0.5, 0.5, 1) (tangent-space +z) keeps the shading normal within 1e-6
// and the frame within 1e-6, on a quad and a sphere (poles included in view). A constant tilted
// map nt = (sin a cos b, sin a sin b, cos a) gives x nt.x + y nt.y + z nt.z in the frame
// x = normalize(sdpdu), z = ns, y = cross(z, x) (pbrt-v4 Frame::FromXZ), at angle a from ns.
TEST(Bump, NormalMapFlatIsIdentity) {
  write_constant_exr("flat.exr", glm::vec3(0.5f, 0.5f, 1.0f));
  const double a = 0.5, b = 0.7;
  const glm::dvec3 nt(std::sin(a) * std::cos(b), std::sin(a) * std::sin(b), std::cos(a));
  write_constant_exr("tilted.exr", glm::vec3(0.5 + 0.5 * nt.x, 0.5 + 0.5 * nt.y, 0.5 + 0.5 * nt.z));
  auto scene = [](const std::string& map) {
    return R"(
LookAt 0 3 -8  0 0.5 0  0 1 0
Camera "perspective" "float fov" [ 40 ]
Film "rgb" "integer xresolution" [ 48 ] "integer yresolution" [ 48 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Material "diffuse" "string normalmap" ")" + map + R"("
Shape "trianglemesh" "point3 P" [ -3 0 -3  3 0 -3  3 0 3  -3 0 3 ]
  "integer indices" [ 0 1 2  0 2 3 ] "point2 uv" [ 0 0  1 0  1 1  0 1 ]
AttributeBegin
  Translate 0 1.2 0
  Rotate -70 1 0 0
  Shape "sphere" "float radius" [ 1 ]
AttributeEnd
)";
  };
  const SceneTables flat = tables_in_temp(scene("flat.exr"));
  const SceneTables tilted = tables_in_temp(scene("tilted.exr"));
  ASSERT_TRUE(flat.features2 & gpu::FEATURE2_NORMALMAP);
  double worst_flat = 0.0, worst_frame = 0.0, worst_tilt = 0.0, worst_angle = 0.0;
  int n[2] = {0, 0};  // quad, sphere hits
  for (std::uint32_t y = 0; y < 48; ++y)
    for (std::uint32_t x = 0; x < 48; ++x) {
      SurfacePoint sp;
      glm::vec3 d;
      std::uint32_t prim = 0;
      if (!camera_hit(flat, x, y, 0u, sp, d, &prim)) continue;
      ++n[(prim & gpu::PRIM_SPHERE_BIT) ? 1 : 0];
      const SurfacePoint before = sp;
      (void)bsdf_at(flat, sp.material, sp, -d);
      ASSERT_TRUE(sane_shading(sp));
      worst_flat = std::max(worst_flat, dist(sp.g.ns, glm::dvec3(before.g.ns)));
      worst_frame = std::max({worst_frame, dist(sp.frame.t1, glm::dvec3(before.frame.t1)),
                              dist(sp.frame.t2, glm::dvec3(before.frame.t2))});

      SurfacePoint st;
      ASSERT_TRUE(camera_hit(tilted, x, y, 0u, st, d));
      const glm::dvec3 z(st.g.ns), xa = glm::normalize(glm::dvec3(st.sdpdu));
      const glm::dvec3 ya = glm::cross(z, xa);
      glm::dvec3 expect = xa * nt.x + ya * nt.y + z * nt.z;
      if (glm::dot(expect, glm::dvec3(st.g.ng)) < 0.0) expect = -expect;
      (void)bsdf_at(tilted, st.material, st, -d);
      ASSERT_TRUE(sane_shading(st));
      worst_tilt = std::max(worst_tilt, dist(st.g.ns, expect));
      worst_angle = std::max(worst_angle, std::fabs(std::acos(std::clamp(
                                              glm::dot(glm::dvec3(st.g.ns), z), -1.0, 1.0)) - a));
    }
  std::printf("[ bump ] normal maps (%d quad, %d sphere hits): flat normal %.3g, flat frame "
              "%.3g, tilted %.3g, tilt angle %.3g\n", n[0], n[1], worst_flat, worst_frame,
              worst_tilt, worst_angle);
  EXPECT_GT(n[0], 500);
  EXPECT_GT(n[1], 200);
  EXPECT_LT(worst_flat, 1e-6);
  EXPECT_LT(worst_frame, 1e-6);
  EXPECT_LT(worst_tilt, 1e-5);
  EXPECT_LT(worst_angle, 1e-4);
}

// A scene without bumps gives the same image, bit for bit, as the same scene written with
// displacements and a normal map whose material flags (and FEATURE2 bits) are then cleared in
// the tables: the bump code runs only under MATFLAG_BUMP / MATFLAG_NORMALMAP, and the data it
// adds (displacement programs, the normal map's level, the shading pair) changes nothing else.
// The flagged scene itself renders differently (the test is not vacuous).
TEST(Bump, UnbumpedScenesUnchanged) {
  write_constant_exr("tilt2.exr", glm::vec3(0.7f, 0.45f, 0.9f));
  auto scene = [](bool with) {
    const std::string disp = with ? R"( "texture displacement" "bumps")" : "";
    const std::string cdisp = with ? R"( "float displacement" [ 0.05 ])" : "";
    const std::string nmap = with ? R"( "string normalmap" "tilt2.exr")" : "";
    return R"(
LookAt 0 2 -6  0 0.6 0  0 1 0
Camera "perspective" "float fov" [ 40 ]
Film "rgb" "integer xresolution" [ 40 ] "integer yresolution" [ 30 ]
Sampler "independent" "integer pixelsamples" [ 8 ]
Integrator "path" "integer maxdepth" [ 5 ]
WorldBegin
LightSource "infinite" "rgb L" [ 0.5 0.5 0.6 ]
LightSource "distant" "rgb L" [ 2 2 2 ] "point3 from" [ 1 4 -2 ] "point3 to" [ 0 0 0 ]
Texture "fbm" "float" "fbm" "integer octaves" [ 5 ]
Texture "bumps" "float" "scale" "texture tex" "fbm" "float scale" [ 0.03 ]
Texture "checks" "spectrum" "checkerboard" "float uscale" [ 8 ] "float vscale" [ 8 ]
Material "diffuse" "texture reflectance" "checks")" + disp + R"(
Shape "trianglemesh" "point3 P" [ -5 0 -5  5 0 -5  5 0 5  -5 0 5 ]
  "integer indices" [ 0 1 2  0 2 3 ] "point2 uv" [ 0 0  1 0  1 1  0 1 ]
AttributeBegin
  Translate -1.2 0.8 0
  Material "conductor" "float roughness" [ 0.1 ])" + cdisp + R"(
  Shape "sphere" "float radius" [ 0.8 ]
AttributeEnd
AttributeBegin
  Translate 1.2 0.8 0
  Material "coateddiffuse" "rgb reflectance" [ 0.2 0.4 0.6 ])" + nmap + R"(
  Shape "sphere" "float radius" [ 0.8 ]
AttributeEnd
AttributeBegin
  Material "dielectric" "float eta" [ 1.5 ]
  Shape "trianglemesh" "point3 P" [ -0.5 0.1 -1.5  0.5 0.1 -1.5  0 1.2 -1.4 ]
    "integer indices" [ 0 1 2 ] "normal N" [ -0.3 0 -1  0.3 0 -1  0 0.3 -1 ]
AttributeEnd
)";
  };
  SceneTables flagged = tables_in_temp(scene(true));
  const SceneTables plain = tables_in_temp(scene(false));
  ASSERT_TRUE(flagged.features2 & gpu::FEATURE2_BUMP);
  ASSERT_TRUE(flagged.features2 & gpu::FEATURE2_NORMALMAP);
  ASSERT_EQ(plain.features2 & (gpu::FEATURE2_BUMP | gpu::FEATURE2_NORMALMAP), 0u);
  const std::vector<glm::vec3> with_bumps = render(Side::Cpu, flagged, 8);
  int flags = 0;
  for (gpu::Material& m : flagged.materials) {
    flags += (m.flags & (gpu::MATFLAG_BUMP | gpu::MATFLAG_NORMALMAP)) != 0;
    m.flags &= ~(gpu::MATFLAG_BUMP | gpu::MATFLAG_NORMALMAP);
  }
  EXPECT_EQ(flags, 3);
  flagged.features2 &= ~(gpu::FEATURE2_BUMP | gpu::FEATURE2_NORMALMAP);
  const std::vector<glm::vec3> cleared = render(Side::Cpu, flagged, 8);
  const std::vector<glm::vec3> ref = render(Side::Cpu, plain, 8);
  ASSERT_EQ(cleared.size(), ref.size());
  EXPECT_EQ(std::memcmp(cleared.data(), ref.data(), ref.size() * sizeof(glm::vec3)), 0)
      << "a render without bump flags differs from the scene without bumps";
  int differ = 0;
  for (std::size_t i = 0; i < ref.size(); ++i) differ += with_bumps[i] != ref[i];
  EXPECT_GT(differ, int(ref.size()) / 4) << "the bumped scene should render differently";
}


// ---- vector turbulence (docs/bump-spec.md 9, Shirley 11.4) -----------------------------------

/// Shirley's vector noise in double from the tables' gradients and permutation, written from
/// seed 002 11.4 (the oracle of the vector-turbulence tests).
glm::dvec3 vector_noise_oracle(const SceneTables& t, glm::dvec3 p) {
  const float* g = t.tex_data.data() + t.globals.tex_tables.z;
  const float* perm = g + 768;
  auto phi = [perm](long i) { return long(perm[((i % 256) + 256) % 256]); };
  auto omega = [](double x) {
    const double a = std::fabs(x);
    return a < 1.0 ? 2.0 * a * a * a - 3.0 * a * a + 1.0 : 0.0;
  };
  glm::dvec3 sum(0.0);
  const long ix = long(std::floor(p.x)), iy = long(std::floor(p.y)), iz = long(std::floor(p.z));
  for (long i = ix; i <= ix + 1; ++i)
    for (long j = iy; j <= iy + 1; ++j)
      for (long k = iz; k <= iz + 1; ++k) {
        const float* gr = g + 3 * phi(i + phi(j + phi(k)));
        sum += omega(p.x - double(i)) * omega(p.y - double(j)) * omega(p.z - double(k)) *
               glm::dvec3(gr[0], gr[1], gr[2]);
      }
  return sum;
}

/// sum over i < octaves of vector_noise_oracle(2^i p) / 2^i.
glm::dvec3 vector_turbulence_oracle(const SceneTables& t, glm::dvec3 p, int octaves) {
  glm::dvec3 sum(0.0);
  for (int i = 0; i < octaves; ++i) sum += vector_noise_oracle(t, std::ldexp(1.0, i) * p) /
                                            std::ldexp(1.0, i);
  return sum;
}

/// A sphere of radius 1.6 (Shirley's Figure 11.12) with "normalturbulence" k1 and scale k2
/// (and an optional extra material line), seen from -z at 64 x 64.
SceneTables vturb_sphere(float k1, float k2, const std::string& extra = "",
                         const std::string& shape = "Shape \"sphere\" \"float radius\" [ 1.6 ]") {
  return tables_from_string(R"(
LookAt 0 0 -8  0 0 0  0 1 0
Camera "perspective" "float fov" [ 30 ]
Film "rgb" "integer xresolution" [ 64 ] "integer yresolution" [ 64 ]
WorldBegin
LightSource "distant" "point3 from" [ 0 10 0 ] "point3 to" [ 0 0 0 ]
Material "diffuse" "float normalturbulence" [ )" + std::to_string(k1) +
                            R"( ] "float normalturbulencescale" [ )" + std::to_string(k2) +
                            " ] " + extra + "\n" + shape + "\n");
}

// At a lattice point the cubic weight is 1 at that corner and 0 at the seven others, so the
// vector noise is the corner's gradient: a unit vector, equal to the table entry; in between it
// agrees with the double-precision oracle within 2e-6 (|p| <= 100, 10^4 points) and is 0 for
// non-finite points.
TEST(VectorTurbulence, NoiseMatchesLatticeAndOracle) {
  const SceneTables t = vturb_sphere(0.08f, 8.0f);
  const float* g = t.tex_data.data() + t.globals.tex_tables.z;
  const float* perm = g + 768;
  auto phi = [perm](int i) { return int(perm[((i % 256) + 256) % 256]); };
  for (int i = -3; i <= 3; ++i)
    for (int j = -3; j <= 3; ++j)
      for (int k = -3; k <= 3; ++k) {
        const glm::vec3 v = vector_noise(t, glm::vec3(float(i), float(j), float(k)));
        const float* gr = g + 3 * phi(i + phi(j + phi(k)));
        ASSERT_EQ(v, glm::vec3(gr[0], gr[1], gr[2])) << i << " " << j << " " << k;
        ASSERT_NEAR(glm::length(v), 1.0f, 1e-6f);
      }
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> u(-100.0f, 100.0f);
  double worst = 0.0, worst_t = 0.0;
  for (int n = 0; n < 10000; ++n) {
    const glm::vec3 p(u(rng), u(rng), u(rng));
    worst = std::max(worst, dist(vector_noise(t, p), vector_noise_oracle(t, glm::dvec3(p))));
    const glm::vec3 q = p * 0.25f;
    worst_t = std::max(worst_t, dist(vector_turbulence(t, q, 4),
                                     vector_turbulence_oracle(t, glm::dvec3(q), 4)));
  }
  std::printf("[ vturb ] vector noise vs double oracle: %.3g; 4-octave turbulence: %.3g\n", worst,
              worst_t);
  EXPECT_LT(worst, 2e-6);
  EXPECT_LT(worst_t, 4e-6);
  EXPECT_EQ(vector_noise(t, glm::vec3(NAN, 0.0f, 0.0f)), glm::vec3(0.0f));
  EXPECT_EQ(vector_noise(t, glm::vec3(0.0f, INFINITY, 0.0f)), glm::vec3(0.0f));
}

// Through the parser, the tables and bsdf_at: at every camera hit of Shirley's sphere the
// shading normal is normalize(n0 + k1 vectorTurbulence(k2 p)) (the oracle in double) within
// 1e-5, the frame is sane and faces ng; with k1 = 0 the normal and frame are the unperturbed
// ones within 1e-6. On a mesh sphere with vertex normals and on a sphere that is also bumped
// (the turbulence perturbs the bumped normal) the same holds with n0 the normal before it.
TEST(VectorTurbulence, NormalIsPerturbedAsShirley) {
  struct Case {
    const char* name;
    float k1;
    std::string extra, shape;
  };
  const std::string mesh = R"(Shape "trianglemesh" "integer indices" [ 0 1 2  0 2 3 ]
  "point3 P" [ -2 -2 0  2 -2 0  2 2 0  -2 2 0 ] "normal N" [ -0.3 -0.3 -1  0.3 -0.3 -1  0.3 0.3 -1  -0.3 0.3 -1 ]
  "point2 uv" [ 0 0 1 0 1 1 0 1 ])";
  const Case cases[] = {
      {"sphere k1 = 0.24", 0.24f, "", "Shape \"sphere\" \"float radius\" [ 1.6 ]"},
      {"sphere k1 = 0", 0.0f, "", "Shape \"sphere\" \"float radius\" [ 1.6 ]"},
      {"mesh with normals", 0.08f, "", mesh},
      {"bumped sphere", 0.08f, "\"float displacement\" [ 0.2 ]",
       "Shape \"sphere\" \"float radius\" [ 1.6 ]"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    const SceneTables t = vturb_sphere(c.k1, 8.0f, c.extra, c.shape);
    ASSERT_NE(t.features2 & gpu::FEATURE2_VTURB, 0u);
    double worst = 0.0;
    int n = 0;
    for (std::uint32_t y = 0; y < 64; ++y)
      for (std::uint32_t x = 0; x < 64; ++x) {
        SurfacePoint sp;
        glm::vec3 d;
        if (!camera_hit(t, x, y, 0u, sp, d)) continue;
        const gpu::Material& m = t.materials[sp.material];
        // n0: the normal after the bump (if any), from the same code path without turbulence.
        gpu::Material plain = m;
        plain.flags &= ~gpu::MATFLAG_VTURB;
        SurfacePoint sp0 = sp;
        bump_shading(t, plain, sp0);
        const SurfacePoint before = sp0;
        (void)bsdf_at(t, sp.material, sp, -d);
        ASSERT_TRUE(sane_shading(sp));
        glm::dvec3 expect = glm::dvec3(before.g.ns) +
                            double(c.k1) * vector_turbulence_oracle(
                                               t, 8.0 * glm::dvec3(sp.tex.p), 4);
        expect = glm::normalize(expect);
        if (glm::dot(expect, glm::dvec3(sp.g.ng)) < 0.0) expect = -expect;
        worst = std::max(worst, dist(sp.g.ns, expect));
        if (c.k1 == 0.0f) {
          ASSERT_LT(dist(sp.frame.t1, glm::dvec3(before.frame.t1)), 1e-6);
          ASSERT_LT(dist(sp.g.ns, glm::dvec3(before.g.ns)), 1e-6);
        }
        ++n;
      }
    std::printf("[ vturb ] %s (%d hits): normal vs oracle %.3g\n", c.name, n, worst);
    EXPECT_GT(n, 400);
    EXPECT_LT(worst, 1e-5);
  }
}

// Extreme inputs: 10^6 random hits with points up to 1e30, amplitudes up to 1e30 (and
// negative), frequencies from 1e-30 to 1e30, zero and non-finite texture points give a finite,
// unit, face-forwarded shading normal and frame (or leave the frame as it was).
TEST(VectorTurbulence, RandomExtremeInputs) {
  SceneTables t = vturb_sphere(0.1f, 1.0f);
  std::mt19937 rng(11);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f), e(-30.0f, 30.0f);
  gpu::Material m = t.materials[0];
  for (gpu::Material& mm : t.materials)
    if (mm.flags & gpu::MATFLAG_VTURB) m = mm;
  ASSERT_NE(m.flags & gpu::MATFLAG_VTURB, 0u);
  int changed = 0;
  for (int n = 0; n < 1000000; ++n) {
    glm::vec3 ng = glm::normalize(glm::vec3(u(rng), u(rng), u(rng)) + glm::vec3(0, 0, 1e-3f));
    SurfacePoint sp = plane_point(glm::vec2(0.5f), 1.0f, 0.0f);
    sp.g.ng = sp.g.ns = ng;
    sp.sdpdu = glm::vec3(u(rng), u(rng), u(rng)) * std::pow(10.0f, e(rng) / 3.0f);
    sp.sdpdv = glm::cross(ng, sp.sdpdu);
    sp.frame = shading_frame(ng, sp.sdpdu);
    const float scale = std::pow(10.0f, e(rng));
    sp.tex.p = glm::vec3(u(rng), u(rng), u(rng)) * scale;
    if (n % 97 == 0) sp.tex.p.x = NAN;
    if (n % 89 == 0) sp.tex.p = glm::vec3(0.0f);
    m.value[gpu::SLOT_NORMALMAP].y = u(rng) * std::pow(10.0f, e(rng));
    m.value[gpu::SLOT_NORMALMAP].z = std::pow(10.0f, e(rng));
    m.value[gpu::SLOT_NORMALMAP].w = float(1 + n % 8);
    changed += bump_shading(t, m, sp);
    ASSERT_TRUE(sane_shading(sp, 1e-4)) << "at sample " << n;
  }
  std::printf("[ vturb ] 10^6 extreme inputs: %d changed the frame, none non-finite\n", changed);
  EXPECT_GT(changed, 100000);
}

// The parameters are checked with located errors, and a material without them is untouched.
TEST(VectorTurbulence, ParameterErrors) {
  const std::string head = R"(Camera "perspective"
WorldBegin
Material "diffuse" )";
  const std::string tail = "\nShape \"sphere\"\n";
  const char* bad[] = {
      "\"float normalturbulencescale\" [ 2 ]",
      "\"float normalturbulence\" [ 0.1 ] \"float normalturbulencescale\" [ 0 ]",
      "\"float normalturbulence\" [ 0.1 ] \"float normalturbulencescale\" [ -1 ]",
      "\"float normalturbulence\" [ 0.1 ] \"integer normalturbulenceoctaves\" [ 0 ]",
      "\"float normalturbulence\" [ 0.1 ] \"integer normalturbulenceoctaves\" [ 17 ]",
      "\"texture normalturbulence\" \"t\"",
  };
  for (const char* b : bad) {
    SCOPED_TRACE(b);
    try {
      (void)tables_from_string(head + b + tail);
      ADD_FAILURE() << "accepted";
    } catch (const SceneError& e) {
      EXPECT_NE(std::string(e.what()).find("normalturbulence"), std::string::npos) << e.what();
      EXPECT_NE(std::string(e.what()).find(":3:"), std::string::npos) << e.what();
    }
  }
  const SceneTables plain = tables_from_string(head + tail);
  EXPECT_EQ(plain.features2 & gpu::FEATURE2_VTURB, 0u);
}

}  // namespace
}  // namespace basalt::test
