// build_tables on hand-made Scenes: lights and their selection pmf, geometry flags and
// degenerate input, camera screen window, the gaussian filter table, feature bits.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <glm/gtc/matrix_transform.hpp>
#include <numbers>

#include "scene/tables.h"

namespace basalt {
namespace {

using gpu::FEATURE_COUNT;
using gpu::FEATURE_FILTER_GAUSSIAN;
using gpu::FEATURE_LIGHT_AREA;
using gpu::FEATURE_LIGHT_DISTANT;
using gpu::FEATURE_LIGHT_INFINITE;
using gpu::FEATURE_LIGHT_POINT;
using gpu::FEATURE_LIGHT_SPOT;
using gpu::FEATURE_MAT_DIFFUSE;
using gpu::FEATURE_SHADING_NORMALS;
using gpu::FEATURE_SPHERES;
using gpu::FEATURE_THIN_LENS;
using gpu::FEATURE_TRIANGLES;
using gpu::FILTER_BOX;
using gpu::FILTER_GAUSSIAN;
using gpu::INVALID_INDEX;
using gpu::LIGHT_AREA_SPHERE;
using gpu::LIGHT_AREA_TRIANGLE;
using gpu::LIGHT_SPOT;
using gpu::MATERIAL_DIFFUSE;
using gpu::PRIM_SPHERE_BIT;
using gpu::SHAPE_FLAG_FLIP_NORMAL;
using gpu::SHAPE_FLAG_HAS_NORMALS;
using gpu::SHAPE_FLAG_HAS_UV;
using gpu::SLOT_DIFFUSE_REFLECTANCE;

Scene base_scene() {
  Scene s;
  s.film.xres = 32;
  s.film.yres = 24;
  s.filter.type = Filter::Type::Box;
  s.filter.radius = glm::vec2(0.5f);
  return s;
}

Shape quad(const glm::mat4& m = glm::mat4(1.0f)) {
  Shape s;
  s.kind = Shape::Kind::Triangles;
  s.world_from_object = m;
  s.mesh.P = {{0, 0, 0}, {1, 0, 0}, {1, 1, 0}, {0, 1, 0}};
  s.mesh.indices = {0, 1, 2, 0, 2, 3};
  return s;
}

Shape sphere(const glm::mat4& m, float radius = 1.0f) {
  Shape s;
  s.kind = Shape::Kind::Sphere;
  s.world_from_object = m;
  s.radius = radius;
  return s;
}

Light point_light(glm::vec3 I, glm::vec3 from = glm::vec3(0.0f)) {
  Light l;
  l.kind = Light::Kind::Point;
  l.value = I;
  l.from = from;
  return l;
}

std::uint32_t float_bits(float f) {
  std::uint32_t u;
  std::memcpy(&u, &f, 4);
  return u;
}

void check_light_distribution(const SceneTables& t) {
  const std::size_t n = t.lights.size();
  ASSERT_EQ(t.light_cdf.size(), n + 1);
  EXPECT_EQ(t.light_cdf[0], 0.0f);
  EXPECT_EQ(t.light_cdf[n], 1.0f);
  double sum = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    EXPECT_LE(t.light_cdf[i], t.light_cdf[i + 1]);
    float diff = t.light_cdf[i + 1] - t.light_cdf[i];
    EXPECT_EQ(float_bits(t.lights[i].pmf), float_bits(diff)) << "light " << i;
    sum += t.lights[i].pmf;
  }
  EXPECT_NEAR(sum, 1.0, 1e-6);
  EXPECT_EQ(t.globals.counts.x, n);
}

TEST(Tables, LightDistributionIsConsistent) {
  Scene s = base_scene();
  s.shapes.push_back(quad());
  s.shapes.back().area_light = AreaLight{glm::vec3(3.0f, 1.0f, 2.0f), true};
  s.shapes.push_back(sphere(glm::translate(glm::mat4(1.0f), glm::vec3(0, 0, 5)), 0.5f));
  s.shapes.back().area_light = AreaLight{glm::vec3(1.0f), false};
  s.lights.push_back(point_light(glm::vec3(1.0f, 2.0f, 3.0f)));
  Light spot;
  spot.kind = Light::Kind::Spot;
  spot.value = glm::vec3(7.0f);
  spot.dir = glm::vec3(0, 0, 2);
  s.lights.push_back(spot);
  Light distant;
  distant.kind = Light::Kind::Distant;
  distant.value = glm::vec3(0.1f);
  distant.dir = glm::vec3(0, 1, 0);
  s.lights.push_back(distant);
  Light inf;
  inf.kind = Light::Kind::Infinite;
  inf.value = glm::vec3(0.01f);
  s.lights.push_back(inf);
  for (int i = 0; i < 20; ++i) s.lights.push_back(point_light(glm::vec3(0.001f * i)));
  SceneTables t = build_tables(s);
  check_light_distribution(t);
  EXPECT_EQ(t.lights.size(), 4u + 20u + 2u + 1u);
  EXPECT_EQ(t.lights[4].pmf, 0.0f);  // the zero-power point light is never picked
  EXPECT_EQ(t.globals.counts.y, 1u);
  EXPECT_EQ(t.globals.infinite_lights, glm::uvec4(3u, INVALID_INDEX, INVALID_INDEX, INVALID_INDEX));
  // Spot: unit axis, cosines of the falloff start and end.
  EXPECT_EQ(t.lights[1].type, LIGHT_SPOT);
  EXPECT_NEAR(t.lights[1].dir.z, 1.0f, 1e-7f);
  EXPECT_NEAR(t.lights[1].params.x, std::cos(25.0 * std::numbers::pi / 180.0), 1e-6);
  EXPECT_NEAR(t.lights[1].params.y, std::cos(30.0 * std::numbers::pi / 180.0), 1e-6);
  // Power ratios follow path-spec section 6: point 4 pi I vs triangle pi L A (twice, two-sided).
  const double point = 4.0 * std::numbers::pi * 2.0;
  const double tri = std::numbers::pi * 2.0 * 0.5 * 2.0;
  EXPECT_NEAR(t.lights[0].pmf / t.lights[24].pmf, point / tri, 1e-5);
  EXPECT_EQ(t.features & (FEATURE_LIGHT_POINT | FEATURE_LIGHT_SPOT | FEATURE_LIGHT_DISTANT |
                          FEATURE_LIGHT_INFINITE | FEATURE_LIGHT_AREA),
            FEATURE_LIGHT_POINT | FEATURE_LIGHT_SPOT | FEATURE_LIGHT_DISTANT |
                FEATURE_LIGHT_INFINITE | FEATURE_LIGHT_AREA);
}

TEST(Tables, TwiceThePowerTwiceThePmf) {
  Scene s = base_scene();
  s.lights.push_back(point_light(glm::vec3(1.0f)));
  s.lights.push_back(point_light(glm::vec3(2.0f, 1.0f, 3.0f)));  // mean 2
  SceneTables t = build_tables(s);
  check_light_distribution(t);
  EXPECT_NEAR(t.lights[1].pmf / t.lights[0].pmf, 2.0, 1e-6);
}

TEST(Tables, NoLightsAndAllZeroPower) {
  Scene s = base_scene();
  SceneTables t = build_tables(s);
  EXPECT_TRUE(t.lights.empty());
  EXPECT_EQ(t.light_cdf, std::vector<float>{0.0f});
  EXPECT_EQ(t.globals.counts.x, 0u);
  EXPECT_TRUE(t.nodes.empty());
  EXPECT_TRUE(t.prim_refs.empty());
  // No geometry: bounding sphere at the camera with radius 1.
  EXPECT_EQ(t.globals.scene_sphere, glm::vec4(0, 0, 0, 1));

  for (int i = 0; i < 3; ++i) s.lights.push_back(point_light(glm::vec3(0.0f)));
  t = build_tables(s);
  check_light_distribution(t);
  for (const gpu::Light& l : t.lights) EXPECT_NEAR(l.pmf, 1.0 / 3.0, 1e-7);
}

TEST(Tables, TooManyInfiniteLights) {
  Scene s = base_scene();
  for (int i = 0; i < 5; ++i) {
    Light l;
    l.kind = Light::Kind::Infinite;
    l.loc = SourceLoc{"lights.pbrt", 10 + i, 1};
    s.lights.push_back(l);
  }
  try {
    build_tables(s);
    FAIL() << "expected SceneError";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.loc.line, 14);
    EXPECT_NE(std::string(e.what()).find("lights.pbrt:14:1: error:"), std::string::npos);
  }
  s.lights.pop_back();
  SceneTables t = build_tables(s);
  EXPECT_EQ(t.globals.counts.y, 4u);
  EXPECT_EQ(t.globals.infinite_lights, glm::uvec4(0, 1, 2, 3));
}

TEST(Tables, NonUniformSphereScaleThrowsWithLocation) {
  Scene s = base_scene();
  s.shapes.push_back(sphere(glm::scale(glm::mat4(1.0f), glm::vec3(1.0f, 2.0f, 1.0f))));
  s.shapes.back().loc = SourceLoc{"scene.pbrt", 7, 3};
  try {
    build_tables(s);
    FAIL() << "expected SceneError";
  } catch (const SceneError& e) {
    EXPECT_EQ(e.loc.file, "scene.pbrt");
    EXPECT_EQ(e.loc.line, 7);
    EXPECT_EQ(e.loc.column, 3);
    EXPECT_EQ(std::string(e.what()),
              "scene.pbrt:7:3: error: non-uniform scale on a sphere is not supported");
  }
  // A shear is not a similarity either.
  glm::mat4 shear(1.0f);
  shear[1][0] = 0.5f;
  s.shapes.back().world_from_object = shear;
  EXPECT_THROW(build_tables(s), SceneError);
  // Bad radius.
  s.shapes.back() = sphere(glm::mat4(1.0f), 0.0f);
  EXPECT_THROW(build_tables(s), SceneError);
}

TEST(Tables, SimilaritySphere) {
  Scene s = base_scene();
  glm::mat4 m = glm::translate(glm::mat4(1.0f), glm::vec3(1, 2, 3)) *
                glm::rotate(glm::mat4(1.0f), 0.7f, glm::normalize(glm::vec3(1, 1, 0))) *
                glm::scale(glm::mat4(1.0f), glm::vec3(2.0f));
  s.shapes.push_back(sphere(m, 1.5f));
  s.shapes.back().area_light = AreaLight{glm::vec3(1.0f), false};
  SceneTables t = build_tables(s);
  ASSERT_EQ(t.spheres.size(), 1u);
  const gpu::Sphere& sp = t.spheres[0];
  EXPECT_NEAR(sp.center_radius.x, 1.0f, 1e-6f);
  EXPECT_NEAR(sp.center_radius.y, 2.0f, 1e-6f);
  EXPECT_NEAR(sp.center_radius.z, 3.0f, 1e-6f);
  EXPECT_NEAR(sp.center_radius.w, 3.0f, 1e-5f);
  EXPECT_NEAR(glm::length(glm::vec3(sp.axis_x)), 1.0f, 1e-6f);
  EXPECT_NEAR(glm::dot(glm::vec3(sp.axis_x), glm::vec3(sp.axis_y)), 0.0f, 1e-6f);
  EXPECT_EQ(sp.light, 0u);
  EXPECT_EQ(t.lights[0].type, LIGHT_AREA_SPHERE);
  EXPECT_EQ(t.lights[0].prim, 0u);
  ASSERT_EQ(t.prim_refs.size(), 1u);
  EXPECT_EQ(t.prim_refs[0], PRIM_SPHERE_BIT | 0u);
  ASSERT_EQ(t.nodes.size(), 1u);
  EXPECT_LE(t.nodes[0].lo.x, -2.0f);
  EXPECT_GE(t.nodes[0].hi.z, 6.0f);
  EXPECT_EQ(t.features & (FEATURE_SPHERES | FEATURE_TRIANGLES), FEATURE_SPHERES);
}

TEST(Tables, DegenerateTrianglesAreDropped) {
  Scene s = base_scene();
  Shape sh;
  sh.kind = Shape::Kind::Triangles;
  sh.loc = SourceLoc{"mesh.pbrt", 4, 1};
  sh.mesh.P = {{0, 0, 0}, {1, 0, 0}, {0, 1, 0}, {2, 0, 0}, {0, 0, 0}};
  //                 kept       collinear   repeated vertex   kept
  sh.mesh.indices = {0, 1, 2, 0, 1, 3, 0, 4, 2, 2, 1, 0};
  sh.area_light = AreaLight{glm::vec3(1.0f), false};
  s.shapes.push_back(quad());  // two triangles before
  s.shapes.push_back(sh);
  std::vector<std::string> warnings;
  SceneTables t = build_tables(s, nullptr, &warnings);
  ASSERT_EQ(t.triangles.size(), 4u);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].rfind("mesh.pbrt:4:1: warning: dropped 2 degenerate triangles", 0), 0u)
      << warnings[0];
  // Kept triangles of the emissive mesh have contiguous lights in triangle order.
  const gpu::Mesh& mesh = t.meshes[1];
  EXPECT_EQ(mesh.tri_base, 2u);
  EXPECT_EQ(mesh.light_base, 0u);
  EXPECT_EQ(t.meshes[0].light_base, INVALID_INDEX);
  ASSERT_EQ(t.lights.size(), 2u);
  for (std::uint32_t k = 0; k < 2; ++k) {
    const gpu::Light& l = t.lights[mesh.light_base + k];
    EXPECT_EQ(l.type, LIGHT_AREA_TRIANGLE);
    EXPECT_EQ(l.prim, mesh.tri_base + k);
    EXPECT_EQ(t.triangles[l.prim].mesh, 1u);
    EXPECT_FLOAT_EQ(l.params.x, 0.5f);
  }
  // The BVH references exactly the kept triangles.
  std::vector<std::uint32_t> refs = t.prim_refs;
  std::sort(refs.begin(), refs.end());
  EXPECT_EQ(refs, (std::vector<std::uint32_t>{0, 1, 2, 3}));
  // Non-finite vertices are dropped too.
  s.shapes.back().mesh.P[2].x = std::numeric_limits<float>::quiet_NaN();
  t = build_tables(s, nullptr, &warnings);
  EXPECT_EQ(t.triangles.size(), 2u);
}

TEST(Tables, TriangleWorldSpaceAndOrientation) {
  Scene s = base_scene();
  glm::mat4 m = glm::translate(glm::mat4(1.0f), glm::vec3(0, 0, 2)) *
                glm::scale(glm::mat4(1.0f), glm::vec3(2.0f, 1.0f, 1.0f));
  Shape a = quad(m);
  a.mesh.N = std::vector<glm::vec3>(4, glm::vec3(1, 0, 1));
  a.mesh.uv = {{0, 0}, {1, 0}, {1, 1}, {0, 1}};
  a.reverse_orientation = true;
  s.shapes.push_back(a);
  Shape mirrored = quad(glm::scale(glm::mat4(1.0f), glm::vec3(-1.0f, 1.0f, 1.0f)));
  s.shapes.push_back(mirrored);
  mirrored.reverse_orientation = true;
  s.shapes.push_back(mirrored);
  s.shapes.push_back(quad());
  s.shapes.push_back(sphere(glm::mat4(1.0f)));
  s.shapes.back().reverse_orientation = true;
  s.shapes.push_back(sphere(glm::scale(glm::mat4(1.0f), glm::vec3(-1.0f, 1.0f, 1.0f))));
  SceneTables t = build_tables(s);
  ASSERT_EQ(t.meshes.size(), 4u);
  EXPECT_EQ(t.meshes[0].flags, SHAPE_FLAG_FLIP_NORMAL | SHAPE_FLAG_HAS_NORMALS | SHAPE_FLAG_HAS_UV);
  EXPECT_EQ(t.meshes[1].flags, SHAPE_FLAG_FLIP_NORMAL);  // mirror swaps handedness
  EXPECT_EQ(t.meshes[2].flags, 0u);                      // reverse xor mirror
  EXPECT_EQ(t.meshes[3].flags, 0u);
  EXPECT_EQ(t.spheres[0].flags, SHAPE_FLAG_FLIP_NORMAL);  // spheres: reverse only
  EXPECT_EQ(t.spheres[1].flags, 0u);
  // World positions, uv in w, normals by the inverse transpose, negated for reverse.
  EXPECT_EQ(glm::vec3(t.vertices[2].p_u), glm::vec3(2, 1, 2));
  EXPECT_EQ(t.vertices[2].p_u.w, 1.0f);
  EXPECT_EQ(t.vertices[2].n_v.w, 1.0f);
  glm::vec3 n = glm::normalize(glm::vec3(0.5f, 0.0f, 1.0f));
  EXPECT_NEAR(t.vertices[0].n_v.x, -n.x, 1e-6f);
  EXPECT_NEAR(t.vertices[0].n_v.z, -n.z, 1e-6f);
  EXPECT_EQ(glm::vec3(t.vertices[4].n_v), glm::vec3(0.0f));  // no normals
  EXPECT_EQ(t.triangles[2].v0, 4u);
  EXPECT_EQ(t.triangles[2].mesh, 1u);
  EXPECT_TRUE(t.features & FEATURE_SHADING_NORMALS);
  EXPECT_TRUE(t.features & FEATURE_TRIANGLES);
  EXPECT_TRUE(t.features & FEATURE_SPHERES);
  // Every primitive is referenced once: 8 triangles and 2 spheres.
  std::vector<std::uint32_t> refs = t.prim_refs;
  std::sort(refs.begin(), refs.end());
  EXPECT_EQ(refs, (std::vector<std::uint32_t>{0, 1, 2, 3, 4, 5, 6, 7, PRIM_SPHERE_BIT,
                                              PRIM_SPHERE_BIT | 1u}));
}

TEST(Tables, ScreenWindowAndCamera) {
  Scene s = base_scene();
  s.film.xres = 320;
  s.film.yres = 240;
  s.camera.fov_deg = 60.0f;
  s.camera.world_from_camera = glm::translate(glm::mat4(1.0f), glm::vec3(1, 2, 3));
  s.sampler.seed = 17;
  s.integrator.max_depth = 7;
  SceneTables t = build_tables(s);
  EXPECT_FLOAT_EQ(t.globals.screen.x, -4.0f / 3.0f);
  EXPECT_FLOAT_EQ(t.globals.screen.y, 4.0f / 3.0f);
  EXPECT_EQ(t.globals.screen.z, -1.0f);
  EXPECT_EQ(t.globals.screen.w, 1.0f);
  EXPECT_NEAR(t.globals.lens.x, std::tan(30.0 * std::numbers::pi / 180.0), 1e-7);
  EXPECT_EQ(t.globals.image, glm::uvec4(320, 240, 7, 17));
  EXPECT_EQ(t.width(), 320u);
  EXPECT_EQ(t.height(), 240u);
  // No geometry: scene sphere at the camera position.
  EXPECT_EQ(t.globals.scene_sphere, glm::vec4(1, 2, 3, 1));
  EXPECT_FALSE(t.features & FEATURE_THIN_LENS);

  s.film.xres = 240;
  s.film.yres = 320;
  s.camera.lens_radius = 0.1f;
  s.camera.focal_distance = 5.0f;
  t = build_tables(s);
  EXPECT_EQ(t.globals.screen.x, -1.0f);
  EXPECT_EQ(t.globals.screen.y, 1.0f);
  EXPECT_FLOAT_EQ(t.globals.screen.z, -4.0f / 3.0f);
  EXPECT_FLOAT_EQ(t.globals.screen.w, 4.0f / 3.0f);
  EXPECT_EQ(t.globals.lens.y, 0.1f);
  EXPECT_EQ(t.globals.lens.z, 5.0f);
  EXPECT_TRUE(t.features & FEATURE_THIN_LENS);

  s.camera.screen_window = glm::vec4(-2, 3, -4, 5);
  t = build_tables(s);
  EXPECT_EQ(t.globals.screen, glm::vec4(-2, 3, -4, 5));
}

TEST(Tables, GaussianFilterTable) {
  Scene s = base_scene();
  s.filter.type = Filter::Type::Gaussian;
  s.filter.radius = glm::vec2(1.5f, 2.0f);
  s.filter.sigma = 0.5f;
  SceneTables t = build_tables(s);
  const std::uint32_t N = t.globals.counts.w;
  EXPECT_EQ(N, 64u);
  EXPECT_EQ(t.globals.counts.z, FILTER_GAUSSIAN);
  EXPECT_EQ(t.globals.filter_radius, glm::vec4(1.5f, 2.0f, 0, 0));
  ASSERT_EQ(t.filter_cdf.size(), 2u * (N + 1));
  EXPECT_TRUE(t.features & FEATURE_FILTER_GAUSSIAN);
  for (int axis = 0; axis < 2; ++axis) {
    const float* cdf = t.filter_cdf.data() + axis * (N + 1);
    EXPECT_EQ(cdf[0], 0.0f);
    EXPECT_EQ(cdf[N], 1.0f);
    for (std::uint32_t i = 0; i < N; ++i) {
      EXPECT_LE(cdf[i], cdf[i + 1]);
      EXPECT_NEAR(cdf[i] + cdf[N - i], 1.0f, 1e-6f) << "symmetry at " << i;
    }
    // Bins near the centre weigh more than bins near the edge; the outermost bin is tiny.
    EXPECT_GT(cdf[N / 2 + 1] - cdf[N / 2], cdf[1] - cdf[0]);
    EXPECT_GT(cdf[1] - cdf[0], 0.0f);
    EXPECT_NEAR(cdf[N / 2], 0.5f, 1e-6f);
  }
  // Box filter: no table.
  s.filter.type = Filter::Type::Box;
  t = build_tables(s);
  EXPECT_TRUE(t.filter_cdf.empty());
  EXPECT_EQ(t.globals.counts.z, FILTER_BOX);
  EXPECT_EQ(t.globals.counts.w, 0u);
  EXPECT_FALSE(t.features & FEATURE_FILTER_GAUSSIAN);
}

TEST(Tables, Materials) {
  Scene s = base_scene();
  Material red;
  red.type = "diffuse";
  red.params["reflectance"] = MaterialParam{{0.8f, 0.1f, 0.2f}, "", {}};
  Material grey;
  grey.type = "diffuse";
  grey.params["reflectance"] = MaterialParam{{0.3f}, "", {}};
  s.materials = {red, grey};
  s.shapes.push_back(quad());
  s.shapes.back().material = 1;
  s.shapes.push_back(quad());  // material -1: default diffuse 0.5, appended once
  s.shapes.push_back(sphere(glm::mat4(1.0f)));
  SceneTables t = build_tables(s);
  ASSERT_EQ(t.materials.size(), 3u);
  EXPECT_EQ(t.materials[0].type, MATERIAL_DIFFUSE);
  EXPECT_EQ(t.materials[0].value[SLOT_DIFFUSE_REFLECTANCE], glm::vec4(0.8f, 0.1f, 0.2f, 0.0f));
  EXPECT_EQ(glm::vec3(t.materials[1].value[0]), glm::vec3(0.3f));
  EXPECT_EQ(glm::vec3(t.materials[2].value[0]), glm::vec3(0.5f));
  EXPECT_EQ(t.materials[2].texture[0], glm::uvec4(INVALID_INDEX));
  EXPECT_EQ(t.materials[2].texture[1], glm::uvec4(INVALID_INDEX));
  EXPECT_EQ(t.meshes[0].material, 1u);
  EXPECT_EQ(t.meshes[1].material, 2u);
  EXPECT_EQ(t.spheres[0].material, 2u);
  EXPECT_TRUE(t.features & FEATURE_MAT_DIFFUSE);

  Material velvet;
  velvet.type = "velvet";
  velvet.loc = SourceLoc{"m.pbrt", 2, 1};
  s.materials.push_back(velvet);
  try {
    build_tables(s);
    FAIL() << "expected SceneError";
  } catch (const SceneError& e) {
    EXPECT_EQ(std::string(e.what()), "m.pbrt:2:1: error: material 'velvet' is not supported yet");
  }
}

// Hand-made materials (no parser): defaults of the kind table, measured offsets, mixes.
TEST(Tables, MaterialsFromScene) {
  Scene s = base_scene();
  s.shapes.push_back(quad());
  s.shapes.back().material = 0;
  Material plastic;
  plastic.type = "plastic";  // no params: pbrt-v3 defaults, remap V3
  Material measured_a, measured_b;
  measured_a.type = measured_b.type = "measured";
  measured_a.measured = 1;
  measured_b.measured = 0;
  MeasuredTable t0, t1;
  t0.dims = glm::uvec3(1, 1, 2);
  t0.rgb = {1, 2, 3, 4, 5, 6};
  t1.dims = glm::uvec3(1, 1, 1);
  t1.rgb = {7, 8, 9};
  s.measured = {t0, t1};
  Material tt1, tt2, mix;
  tt1.type = tt2.type = "translucent";
  mix.type = "mix";
  mix.mix_v3 = true;
  mix.mix[0] = 4;
  mix.mix[1] = 5;
  s.materials = {plastic, measured_a, measured_b, mix, tt1, tt2};
  // Feature bits come from the materials shapes reach (and, through mixes, their children).
  for (int m : {0, 1, 3}) {
    Shape sh;
    sh.material = m;
    s.shapes.push_back(sh);
  }
  SceneTables t = build_tables(s);
  ASSERT_EQ(t.materials.size(), 6u);
  EXPECT_EQ(t.materials[0].type, gpu::MATERIAL_PLASTIC);
  EXPECT_EQ(t.materials[0].flags, gpu::MATFLAG_REMAP_V3);
  EXPECT_EQ(t.materials[0].value[gpu::SLOT_PLASTIC_ROUGH].x, 0.1f);
  EXPECT_EQ(t.measured, (std::vector<float>{1, 2, 3, 4, 5, 6, 7, 8, 9}));
  EXPECT_EQ(t.materials[1].aux0, 6u);  // table 1 follows table 0
  EXPECT_EQ(t.materials[2].aux0, 0u);
  EXPECT_EQ(t.materials[1].value[gpu::SLOT_MEASURED_DIMS], glm::vec4(1, 1, 1, 0));
  // Two translucent materials: 4 + 4 lobes = MAX_LOBES, accepted as a weighted mix.
  EXPECT_EQ(t.materials[3].type, gpu::MATERIAL_MIX_WEIGHTED);
  EXPECT_EQ(t.materials[3].value[gpu::SLOT_MIX_AMOUNT], glm::vec4(0.5f, 0.5f, 0.5f, 0.0f));
  EXPECT_TRUE(t.features & gpu::FEATURE_MAT_MIX_WEIGHTED);
  EXPECT_TRUE(t.features & gpu::FEATURE_MAT_MEASURED);
  EXPECT_FALSE(t.features & gpu::FEATURE_MAT_MIX);
  // The mix mode of the scene decides.
  s.mix_mode = MixMode::Stochastic;
  EXPECT_EQ(build_tables(s).materials[3].type, gpu::MATERIAL_MIX);
  // An unresolved child is an error at the mix.
  s.materials[3].mix[1] = -1;
  s.materials[3].loc = SourceLoc{"x.pbrt", 7, 2};
  try {
    build_tables(s);
    FAIL() << "expected SceneError";
  } catch (const SceneError& e) {
    EXPECT_EQ(std::string(e.what()), "x.pbrt:7:2: error: mix refers to an undefined material");
  }
}

TEST(Tables, SceneSphereAndBvhTiming) {
  Scene s = base_scene();
  s.shapes.push_back(quad(glm::translate(glm::mat4(1.0f), glm::vec3(-1, -1, 0)) *
                          glm::scale(glm::mat4(1.0f), glm::vec3(2.0f))));
  BuildTimes times;
  times.seconds_bvh = -1.0;
  SceneTables t = build_tables(s, &times);
  EXPECT_GE(times.seconds_bvh, 0.0);
  EXPECT_EQ(glm::vec3(t.globals.scene_sphere), glm::vec3(0.0f));
  EXPECT_FLOAT_EQ(t.globals.scene_sphere.w, std::sqrt(2.0f));
  // Distant light power uses that radius: pi R^2 L against a point light's 4 pi I.
  Light distant;
  distant.kind = Light::Kind::Distant;
  distant.value = glm::vec3(2.0f);
  s.lights.push_back(distant);
  s.lights.push_back(point_light(glm::vec3(1.0f)));
  t = build_tables(s);
  EXPECT_NEAR(t.lights[0].pmf / t.lights[1].pmf, (2.0 * 2.0) / 4.0, 1e-5);
}

TEST(Tables, FeatureNames) {
  EXPECT_TRUE(feature_names(0).empty());
  EXPECT_EQ(feature_names(FEATURE_TRIANGLES | FEATURE_LIGHT_AREA | FEATURE_SHADING_NORMALS),
            (std::vector<std::string>{"triangles", "light_area", "shading_normals"}));
  std::vector<std::string> all = feature_names(0xffffffffu);
  EXPECT_EQ(all.size(), FEATURE_COUNT);
  EXPECT_EQ(all[7], "material_diffuse");
  EXPECT_EQ(all[11], "material_oren_nayar");
  EXPECT_EQ(all[22], "material_measured");
  EXPECT_EQ(all[27], "material_metal");
  EXPECT_EQ(all[31], "light_infinite_image");
  for (const std::string& n : all) EXPECT_EQ(n.rfind("feature_", 0), std::string::npos) << n;
}

}  // namespace
}  // namespace basalt

// Light selection follows pbrt-v4's BVHLightSampler top split: each infinite-extent light
// gets 1 / (n_inf + 1), bounded lights share the rest by power (path-spec section 6).
TEST(TablesLightSplit, InfiniteExtentLightsGetAnEqualShare) {
  basalt::Scene s;
  basalt::Light inf;
  inf.kind = basalt::Light::Kind::Infinite;
  inf.value = glm::vec3(100.0f);
  basalt::Light dist;
  dist.kind = basalt::Light::Kind::Distant;
  dist.value = glm::vec3(0.5f);
  basalt::Light p1, p2;
  p1.kind = p2.kind = basalt::Light::Kind::Point;
  p1.value = glm::vec3(1.0f);
  p2.value = glm::vec3(3.0f);
  s.lights = {inf, dist, p1, p2};
  basalt::SceneTables t = basalt::build_tables(s);
  ASSERT_EQ(t.lights.size(), 4u);
  EXPECT_NEAR(t.lights[0].pmf, 1.0f / 3.0f, 1e-6f);
  EXPECT_NEAR(t.lights[1].pmf, 1.0f / 3.0f, 1e-6f);
  EXPECT_NEAR(t.lights[2].pmf, 1.0f / 3.0f * 0.25f, 1e-6f);
  EXPECT_NEAR(t.lights[3].pmf, 1.0f / 3.0f * 0.75f, 1e-6f);
  // Only infinite-extent lights: equal shares, whatever their power.
  s.lights = {inf, dist};
  t = basalt::build_tables(s);
  EXPECT_NEAR(t.lights[0].pmf, 0.5f, 1e-6f);
  EXPECT_NEAR(t.lights[1].pmf, 0.5f, 1e-6f);
}
