// pbrt-v4 scene parser: every supported directive checked numerically, and every class of bad
// input checked for its exact file:line:column.
#include <gtest/gtest.h>

#include <sys/stat.h>

#include <filesystem>
#include <fstream>
#include <glm/gtc/matrix_transform.hpp>
#include <string>

#include "common/scratch_dir.h"
#include "scene/materials.h"
#include "scene/merl.h"
#include "scene/scene.h"
#include "scene/spectra.h"
#include "scene/tables.h"
#include "scene/tokenizer.h"

namespace fs = std::filesystem;
using basalt::load_scene;
using basalt::load_scene_from_string;
using basalt::Scene;
using basalt::SceneError;

namespace {

// Parses text as file "t.pbrt".
Scene parse(const std::string& text, const std::string& base_dir = ".") {
  return load_scene_from_string(text, "t.pbrt", base_dir);
}

// The what() of the SceneError that parsing text throws ("" if it parses).
std::string error_of(const std::string& text, const std::string& base_dir = ".") {
  try {
    parse(text, base_dir);
  } catch (const SceneError& e) {
    return e.what();
  }
  return "";
}

// A fresh empty directory of this process (removed at exit).
fs::path temp_dir(const std::string& name) { return basalt::test::fresh_scratch_dir("parser-" + name); }

// Writes text to path.
void write_file(const fs::path& path, const std::string& text) {
  fs::create_directories(path.parent_path());
  std::ofstream(path, std::ios::binary) << text;
}

// Expects two matrices equal to within eps, element by element.
void expect_mat_near(const glm::mat4& a, const glm::mat4& b, float eps = 1e-5f) {
  for (int c = 0; c < 4; ++c)
    for (int r = 0; r < 4; ++r)
      EXPECT_NEAR(a[c][r], b[c][r], eps) << "column " << c << " row " << r;
}

void expect_vec_near(glm::vec3 a, glm::vec3 b, float eps = 1e-5f) {
  EXPECT_NEAR(a.x, b.x, eps);
  EXPECT_NEAR(a.y, b.y, eps);
  EXPECT_NEAR(a.z, b.z, eps);
}

// True if some warning equals w.
bool has_warning(const Scene& s, const std::string& w) {
  for (const std::string& x : s.warnings)
    if (x == w) return true;
  return false;
}

const char* kSphere = "WorldBegin\nShape \"sphere\"\n";

}  // namespace

// ---- tokenizer ---------------------------------------------------------------------------

TEST(ParserTokenizer, KindsAndLocations) {
  basalt::Tokenizer tok("# comment\n  Shape \"a \\\"q\\\"\"\t[ -1.5e2 +3 .5 ]# c\ntrue", "f");
  using K = basalt::Token::Kind;
  auto t = tok.next();
  ASSERT_TRUE(t);
  EXPECT_EQ(t->kind, K::Word);
  EXPECT_EQ(t->text, "Shape");
  EXPECT_EQ(t->loc.str(), "f:2:3");
  t = tok.next();
  EXPECT_EQ(t->kind, K::String);
  EXPECT_EQ(t->text, "a \"q\"");
  EXPECT_EQ(t->loc.str(), "f:2:9");
  t = tok.next();
  EXPECT_EQ(t->kind, K::LBracket);
  EXPECT_EQ(t->loc.str(), "f:2:19");
  t = tok.next();
  EXPECT_EQ(t->kind, K::Number);
  EXPECT_EQ(t->number, -150.0);
  EXPECT_FALSE(t->is_integer_literal());
  t = tok.next();
  EXPECT_EQ(t->number, 3.0);
  EXPECT_TRUE(t->is_integer_literal());
  t = tok.next();
  EXPECT_EQ(t->number, 0.5);
  EXPECT_EQ(tok.next()->kind, K::RBracket);
  t = tok.next();
  EXPECT_EQ(t->kind, K::Word);
  EXPECT_EQ(t->text, "true");
  EXPECT_EQ(t->loc.str(), "f:3:1");
  EXPECT_FALSE(tok.next());
}

// ---- defaults ------------------------------------------------------------------------------

TEST(Parser, DefaultsFollowPbrtV4) {
  Scene s = parse(kSphere);
  EXPECT_EQ(s.camera.fov_deg, 90.0f);
  EXPECT_EQ(s.camera.lens_radius, 0.0f);
  EXPECT_EQ(s.camera.focal_distance, 1e6f);
  EXPECT_FALSE(s.camera.screen_window.has_value());
  expect_mat_near(s.camera.world_from_camera, glm::mat4(1.0f));
  EXPECT_EQ(s.film.xres, 1280);
  EXPECT_EQ(s.film.yres, 720);
  EXPECT_EQ(s.film.filename, "pbrt.exr");
  EXPECT_EQ(s.sampler.spp, 16);
  EXPECT_EQ(s.sampler.seed, 0);
  EXPECT_EQ(s.filter.type, basalt::Filter::Type::Gaussian);
  EXPECT_EQ(s.filter.radius, glm::vec2(1.5f));
  EXPECT_EQ(s.filter.sigma, 0.5f);
  EXPECT_EQ(s.integrator.max_depth, 5);
  EXPECT_FALSE(s.integrator.regularize);
  ASSERT_EQ(s.shapes.size(), 1u);
  const basalt::Shape& sh = s.shapes[0];
  EXPECT_EQ(sh.kind, basalt::Shape::Kind::Sphere);
  EXPECT_EQ(sh.radius, 1.0f);
  EXPECT_FALSE(sh.reverse_orientation);
  EXPECT_FALSE(sh.area_light.has_value());
  EXPECT_EQ(sh.loc.str(), "t.pbrt:2:1");
  // pbrt-v4's default material: diffuse, reflectance 0.5.
  ASSERT_GE(sh.material, 0);
  const basalt::Material& m = s.materials[sh.material];
  EXPECT_EQ(m.type, "diffuse");
  EXPECT_EQ(m.params.at("reflectance").value, (std::vector<float>{0.5f, 0.5f, 0.5f}));
  EXPECT_TRUE(s.warnings.empty());
}

// ---- camera and options ---------------------------------------------------------------------

TEST(Parser, LookAtMatchesPbrtDefinition) {
  Scene s = parse(
      "LookAt 1 2 3  4 6 3  0 0 1\n"
      "Camera \"perspective\" \"float fov\" 45 \"float lensradius\" 0.1 "
      "\"float focaldistance\" 7\n" +
      std::string(kSphere));
  // pbrt-v4 LookAt: worldFromCamera columns (right, up', dir, eye).
  glm::vec3 eye(1, 2, 3), look(4, 6, 3), up(0, 0, 1);
  glm::vec3 dir = glm::normalize(look - eye);
  glm::vec3 right = glm::normalize(glm::cross(glm::normalize(up), dir));
  glm::vec3 up2 = glm::cross(dir, right);
  glm::mat4 expected(glm::vec4(right, 0), glm::vec4(up2, 0), glm::vec4(dir, 0), glm::vec4(eye, 1));
  expect_mat_near(s.camera.world_from_camera, expected);
  // dir = (0.6, 0.8, 0): right = up x dir = (-0.8, 0.6, 0) (left-handed camera space).
  expect_vec_near(right, glm::vec3(-0.8f, 0.6f, 0.0f));
  EXPECT_EQ(s.camera.fov_deg, 45.0f);
  EXPECT_FLOAT_EQ(s.camera.lens_radius, 0.1f);
  EXPECT_EQ(s.camera.focal_distance, 7.0f);
  EXPECT_EQ(s.camera.loc.str(), "t.pbrt:2:1");
}

TEST(Parser, CameraIsInverseOfCtmAndNamesCameraSpace) {
  Scene s = parse(
      "Scale -1 1 1\nTranslate 0 0 5\nCamera \"perspective\"\n"
      "WorldBegin\nCoordSysTransform \"camera\"\nShape \"sphere\"\n");
  glm::mat4 ctm = glm::scale(glm::mat4(1), glm::vec3(-1, 1, 1)) *
                  glm::translate(glm::mat4(1), glm::vec3(0, 0, 5));
  expect_mat_near(s.camera.world_from_camera, glm::inverse(ctm));
  // A shape in camera space sits at the camera: the CTM became worldFromCamera.
  expect_mat_near(s.shapes[0].world_from_object, glm::inverse(ctm));
}

TEST(Parser, ScreenWindowAndFrameAspectRatio) {
  Scene s = parse("Camera \"perspective\" \"float screenwindow\" [-1 1 -0.5 0.5]\n" +
                  std::string(kSphere));
  ASSERT_TRUE(s.camera.screen_window);
  EXPECT_EQ(*s.camera.screen_window, glm::vec4(-1, 1, -0.5f, 0.5f));
  s = parse("Camera \"perspective\" \"float frameaspectratio\" 2\n" + std::string(kSphere));
  ASSERT_TRUE(s.camera.screen_window);
  EXPECT_EQ(*s.camera.screen_window, glm::vec4(-2, 2, -1, 1));
  s = parse("Camera \"perspective\" \"float frameaspectratio\" 0.5\n" + std::string(kSphere));
  EXPECT_EQ(*s.camera.screen_window, glm::vec4(-1, 1, -2, 2));
}

TEST(Parser, FilmSamplerFilterIntegrator) {
  Scene s = parse(
      "Film \"rgb\" \"integer xresolution\" [ 320 ] \"integer yresolution\" 200 "
      "\"string filename\" \"out.exr\"\n"
      "Sampler \"independent\" \"integer pixelsamples\" 64 \"integer seed\" 7\n"
      "PixelFilter \"box\"\n"
      "Integrator \"path\" \"integer maxdepth\" 9 \"bool regularize\" false\n" +
      std::string(kSphere));
  EXPECT_EQ(s.film.xres, 320);
  EXPECT_EQ(s.film.yres, 200);
  EXPECT_EQ(s.film.filename, "out.exr");
  EXPECT_EQ(s.film.loc.str(), "t.pbrt:1:1");
  EXPECT_EQ(s.sampler.spp, 64);
  EXPECT_EQ(s.sampler.seed, 7);
  EXPECT_EQ(s.filter.type, basalt::Filter::Type::Box);
  EXPECT_EQ(s.filter.radius, glm::vec2(0.5f));
  EXPECT_EQ(s.integrator.max_depth, 9);
  EXPECT_FALSE(s.integrator.regularize);
  EXPECT_TRUE(s.warnings.empty());

  s = parse(
      "PixelFilter \"gaussian\" \"float xradius\" 2 \"float sigma\" 0.25\n"
      "Integrator \"path\" \"bool regularize\" \"false\"\n" +
      std::string(kSphere));
  EXPECT_EQ(s.filter.type, basalt::Filter::Type::Gaussian);
  EXPECT_EQ(s.filter.radius, glm::vec2(2.0f, 1.5f));
  EXPECT_EQ(s.filter.sigma, 0.25f);
  EXPECT_FALSE(s.integrator.regularize);
}

TEST(Parser, AcceptedWithWarnings) {
  Scene s = parse(
      "Film \"gbuffer\"\nSampler \"halton\" \"integer pixelsamples\" 8\n"
      "Integrator \"volpath\"\n" +
      std::string(kSphere));
  EXPECT_EQ(s.sampler.spp, 8);
  EXPECT_TRUE(has_warning(s, "t.pbrt:1:1: warning: Film 'gbuffer' is rendered as Film 'rgb'"));
  EXPECT_EQ(s.sampler.type, "halton");  // honoured (docs/sampler-spec.md), no warning
  for (const std::string& w : s.warnings) EXPECT_EQ(w.find("warning: Sampler"), std::string::npos);
  EXPECT_TRUE(has_warning(s,
                          "t.pbrt:3:1: warning: Integrator 'volpath' is rendered as 'path' "
                          "(basalt has no participating media)"));
  // pbrt-v4 StratifiedSampler: xsamples * ysamples per pixel.
  s = parse("Sampler \"stratified\" \"integer xsamples\" 3 \"integer ysamples\" 5\n" +
            std::string(kSphere));
  EXPECT_EQ(s.sampler.spp, 15);
  EXPECT_EQ(s.sampler.xsamples, 3);
  EXPECT_EQ(s.sampler.ysamples, 5);
  // Sample counts above 2^24 are refused where they are written (issue 11, defect 1).
  EXPECT_THROW(parse("Sampler \"stratified\" \"integer xsamples\" 65536 \"integer ysamples\" "
                     "65536\n" + std::string(kSphere)),
               SceneError);
  EXPECT_THROW(parse("Sampler \"halton\" \"integer pixelsamples\" 16777217\n" +
                     std::string(kSphere)),
               SceneError);
  EXPECT_THROW(parse("Sampler \"halton\" \"string randomization\" \"fastowen\"\n" +
                     std::string(kSphere)),
               SceneError);
  EXPECT_THROW(parse("Sampler \"lowdiscrepancy\"\n" + std::string(kSphere)), SceneError);
  // Every sampler pbrt-v4 names is honoured, sobol with its randomization; pmj02bn refuses
  // more than 65536 samples per pixel, located at the count (pbrt-v4 refuses them too).
  s = parse("Sampler \"pmj02bn\"\n" + std::string(kSphere));
  EXPECT_EQ(s.sampler.type, "pmj02bn");
  EXPECT_EQ(s.sampler.spp, 16);
  EXPECT_TRUE(s.warnings.empty());
  s = parse("Sampler \"sobol\" \"string randomization\" \"owen\" \"integer pixelsamples\" 8\n" +
            std::string(kSphere));
  EXPECT_EQ(s.sampler.type, "sobol");
  EXPECT_EQ(s.sampler.randomization, "owen");
  EXPECT_EQ(s.sampler.spp, 8);
  try {
    parse("Sampler \"pmj02bn\"\n  \"integer pixelsamples\" 65537\n" + std::string(kSphere));
    ADD_FAILURE() << "pmj02bn accepted 65537 samples per pixel";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("t.pbrt:2:3"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("at most 65536"), std::string::npos) << e.what();
  }
}

TEST(Parser, OptionSeedIsTheDefaultSamplerSeed) {
  Scene s = parse("Option \"integer seed\" 42\n" + std::string(kSphere));
  EXPECT_EQ(s.sampler.seed, 42);
  s = parse("Option \"seed\" 42\nSampler \"zsobol\" \"integer seed\" 3\n" + std::string(kSphere));
  EXPECT_EQ(s.sampler.seed, 3);
  s = parse("Option \"bool disablepixeljitter\" true\nOption \"frobnicate\" 1\n" +
            std::string(kSphere));
  EXPECT_TRUE(has_warning(s,
                          "t.pbrt:1:1: warning: Option \"disablepixeljitter\" has no effect "
                          "in basalt"));
  EXPECT_TRUE(has_warning(s, "t.pbrt:2:1: warning: unknown Option \"frobnicate\" ignored"));
}

TEST(Parser, UnusedParametersWarnWithLocation) {
  Scene s = parse(
      "Film \"rgb\" \"bool savefp16\" false\n"
      "   \"float iso\" 400 \"float diagonal\" 35\n"
      "Camera \"perspective\" \"float shutterclose\" 1\n"
      "WorldBegin\nShape \"sphere\" \"float alpha\" 0.5\n");
  const char* suffix = " (not supported by basalt; ignored)";
  EXPECT_TRUE(has_warning(s, std::string("t.pbrt:1:12: warning: unused parameter \"bool savefp16\" "
                                         "for Film 'rgb'") +
                                 suffix));
  EXPECT_TRUE(has_warning(s, std::string("t.pbrt:2:4: warning: unused parameter \"float iso\" for "
                                         "Film 'rgb'") +
                                 suffix));
  EXPECT_TRUE(has_warning(s, std::string("t.pbrt:2:20: warning: unused parameter \"float "
                                         "diagonal\" for Film 'rgb'") +
                                 suffix));
  EXPECT_TRUE(has_warning(s, std::string("t.pbrt:3:22: warning: unused parameter \"float "
                                         "shutterclose\" for Camera 'perspective'") +
                                 suffix));
  EXPECT_TRUE(has_warning(s, std::string("t.pbrt:5:16: warning: unused parameter \"float alpha\" "
                                         "for Shape 'sphere'") +
                                 suffix));
  EXPECT_EQ(s.warnings.size(), 5u);
}

TEST(Parser, LaterParameterWinsAndShadowsQuietly) {
  Scene s =
      parse("Camera \"perspective\" \"float fov\" 30 \"float fov\" 60\n" + std::string(kSphere));
  EXPECT_EQ(s.camera.fov_deg, 60.0f);
  EXPECT_TRUE(s.warnings.empty());
}

// ---- transformations -----------------------------------------------------------------------

TEST(Parser, TransformDirectives) {
  Scene s = parse(
      "WorldBegin\n"
      "AttributeBegin Translate 1 2 3 Shape \"sphere\" AttributeEnd\n"
      "AttributeBegin Scale 2 3 4 Shape \"sphere\" AttributeEnd\n"
      "AttributeBegin Rotate 30 1 1 0 Shape \"sphere\" AttributeEnd\n"
      // pbrt writes Transform column by column: the last four numbers are the translation.
      "AttributeBegin Translate 9 9 9 Transform [1 0 0 0  0 2 0 0  0 0 1 0  5 6 7 1] "
      "Shape \"sphere\" AttributeEnd\n"
      "AttributeBegin Translate 1 0 0 ConcatTransform [0 1 0 0  -1 0 0 0  0 0 1 0  0 0 0 1] "
      "Shape \"sphere\" AttributeEnd\n"
      "AttributeBegin Translate 1 0 0 Identity Shape \"sphere\" AttributeEnd\n");
  ASSERT_EQ(s.shapes.size(), 6u);
  expect_mat_near(s.shapes[0].world_from_object, glm::translate(glm::mat4(1), glm::vec3(1, 2, 3)));
  expect_mat_near(s.shapes[1].world_from_object, glm::scale(glm::mat4(1), glm::vec3(2, 3, 4)));
  // pbrt-v4 Rotate is the right-handed rotation glm::rotate also builds.
  expect_mat_near(s.shapes[2].world_from_object, glm::rotate(glm::mat4(1), glm::radians(30.0f),
                                                             glm::normalize(glm::vec3(1, 1, 0))));
  glm::mat4 t(1.0f);
  t[1][1] = 2;
  t[3] = glm::vec4(5, 6, 7, 1);
  expect_mat_near(s.shapes[3].world_from_object, t);
  // ConcatTransform post-multiplies: world = T(1,0,0) * Rz(90).
  glm::mat4 c = glm::translate(glm::mat4(1), glm::vec3(1, 0, 0)) *
                glm::rotate(glm::mat4(1), glm::radians(90.0f), glm::vec3(0, 0, 1));
  expect_mat_near(s.shapes[4].world_from_object, c);
  expect_mat_near(s.shapes[5].world_from_object, glm::mat4(1.0f));
}

TEST(Parser, WorldBeginResetsCtmAndCoordinateSystems) {
  Scene s = parse(
      "Translate 5 0 0\nCoordinateSystem \"shifted\"\nWorldBegin\n"
      "Translate 0 1 0\nCoordinateSystem \"up\"\nShape \"sphere\"\n"
      "CoordSysTransform \"shifted\"\nShape \"sphere\"\n"
      "CoordSysTransform \"world\"\nShape \"sphere\"\n"
      "CoordSysTransform \"up\"\nShape \"sphere\"\n"
      "CoordSysTransform \"nowhere\"\nShape \"sphere\"\n");
  expect_mat_near(s.shapes[0].world_from_object, glm::translate(glm::mat4(1), glm::vec3(0, 1, 0)));
  expect_mat_near(s.shapes[1].world_from_object, glm::translate(glm::mat4(1), glm::vec3(5, 0, 0)));
  expect_mat_near(s.shapes[2].world_from_object, glm::mat4(1));
  expect_mat_near(s.shapes[3].world_from_object, glm::translate(glm::mat4(1), glm::vec3(0, 1, 0)));
  expect_mat_near(s.shapes[4].world_from_object, glm::translate(glm::mat4(1), glm::vec3(0, 1, 0)));
  EXPECT_TRUE(has_warning(s,
                          "t.pbrt:13:1: warning: unknown coordinate system \"nowhere\"; "
                          "CoordSysTransform ignored"));
}

TEST(Parser, AttributeScopeRestoresState) {
  Scene s = parse(
      "WorldBegin\n"
      "Material \"diffuse\" \"rgb reflectance\" [0.1 0.2 0.3]\n"
      "AttributeBegin\n"
      "  Translate 1 0 0\n  ReverseOrientation\n"
      "  Material \"diffuse\" \"rgb reflectance\" [0.9 0.9 0.9]\n"
      "  AreaLightSource \"diffuse\" \"rgb L\" [1 2 3] \"float scale\" 2 \"bool twosided\" true\n"
      "  Shape \"sphere\" \"float radius\" 0.5\n"
      "AttributeEnd\n"
      "Shape \"sphere\"\n"
      "TransformBegin\n  Translate 0 3 0\n  ReverseOrientation\nTransformEnd\n"
      "Shape \"sphere\"\n");
  ASSERT_EQ(s.shapes.size(), 3u);
  const basalt::Shape &in = s.shapes[0], &out = s.shapes[1];
  expect_mat_near(in.world_from_object, glm::translate(glm::mat4(1), glm::vec3(1, 0, 0)));
  EXPECT_TRUE(in.reverse_orientation);
  ASSERT_TRUE(in.area_light);
  EXPECT_EQ(in.area_light->L, glm::vec3(2, 4, 6));
  EXPECT_TRUE(in.area_light->twosided);
  EXPECT_EQ(in.radius, 0.5f);
  EXPECT_EQ(s.materials[in.material].params.at("reflectance").value,
            (std::vector<float>{0.9f, 0.9f, 0.9f}));
  expect_mat_near(out.world_from_object, glm::mat4(1));
  EXPECT_FALSE(out.reverse_orientation);
  EXPECT_FALSE(out.area_light);
  EXPECT_EQ(s.materials[out.material].params.at("reflectance").value,
            (std::vector<float>{0.1f, 0.2f, 0.3f}));
  // TransformBegin/End: deprecated in pbrt-v4 and handled as AttributeBegin/End.
  expect_mat_near(s.shapes[2].world_from_object, glm::mat4(1));
  EXPECT_FALSE(s.shapes[2].reverse_orientation);
  EXPECT_TRUE(has_warning(s,
                          "t.pbrt:11:1: warning: TransformBegin/TransformEnd are deprecated; "
                          "treated as AttributeBegin/End"));
}

// ---- materials -----------------------------------------------------------------------------

TEST(Parser, NamedMaterials) {
  Scene s = parse(
      "WorldBegin\n"
      "NamedMaterial \"late\"\nShape \"sphere\"\n"  // pbrt-v4 resolves names after parsing
      "MakeNamedMaterial \"red\" \"string type\" \"diffuse\" \"rgb reflectance\" [0.8 0.1 0.1]\n"
      "MakeNamedMaterial \"late\" \"string type\" [\"diffuse\"]\n"
      "NamedMaterial \"red\"\nShape \"sphere\"\n"
      "AttributeBegin Material \"diffuse\" Shape \"sphere\" AttributeEnd\n"
      "Shape \"sphere\"\n");
  ASSERT_EQ(s.shapes.size(), 4u);
  const basalt::Material& late = s.materials[s.shapes[0].material];
  EXPECT_EQ(late.name, "late");
  EXPECT_EQ(late.type, "diffuse");
  EXPECT_EQ(late.params.at("reflectance").value, (std::vector<float>{0.5f, 0.5f, 0.5f}));
  const basalt::Material& red = s.materials[s.shapes[1].material];
  EXPECT_EQ(red.name, "red");
  EXPECT_EQ(red.params.at("reflectance").value, (std::vector<float>{0.8f, 0.1f, 0.1f}));
  EXPECT_EQ(red.params.at("reflectance").loc.str(), "t.pbrt:4:49");
  EXPECT_EQ(s.materials[s.shapes[2].material].name, "");
  EXPECT_EQ(s.shapes[3].material, s.shapes[1].material);
  EXPECT_TRUE(s.warnings.empty());
}

TEST(Parser, ConstantSpectrumIsGrey) {
  Scene s = parse(
      "WorldBegin\nMaterial \"diffuse\" \"spectrum reflectance\" [300 0.25 800 0.25]\n"
      "Shape \"sphere\"\n");
  EXPECT_EQ(s.materials[s.shapes[0].material].params.at("reflectance").value,
            (std::vector<float>{0.25f, 0.25f, 0.25f}));
}

// ---- shapes --------------------------------------------------------------------------------

TEST(Parser, TriangleMesh) {
  Scene s = parse(
      "WorldBegin\n"
      "Shape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 0] \"integer indices\" [0 1 2 2 "
      "1 3]\n"
      "  \"normal N\" [0 0 1 0 0 1 0 0 1 0 0 1] \"point2 uv\" [0 0 1 0 0 1 1 1]\n"
      "Shape \"trianglemesh\" \"point P\" [0 0 0 1 0 0 0 1 0]\n");
  ASSERT_EQ(s.shapes.size(), 2u);
  const basalt::TriangleMesh& m = s.shapes[0].mesh;
  EXPECT_EQ(s.shapes[0].kind, basalt::Shape::Kind::Triangles);
  ASSERT_EQ(m.P.size(), 4u);
  EXPECT_EQ(m.P[3], glm::vec3(1, 1, 0));
  EXPECT_EQ(m.indices, (std::vector<unsigned>{0, 1, 2, 2, 1, 3}));
  ASSERT_EQ(m.N.size(), 4u);
  EXPECT_EQ(m.N[0], glm::vec3(0, 0, 1));
  ASSERT_EQ(m.uv.size(), 4u);
  EXPECT_EQ(m.uv[3], glm::vec2(1, 1));
  // indices may be left out for exactly three vertices (pbrt-v4 TriangleMesh::Create).
  EXPECT_EQ(s.shapes[1].mesh.indices, (std::vector<unsigned>{0, 1, 2}));
  EXPECT_TRUE(s.shapes[1].mesh.N.empty());
}

// ---- lights --------------------------------------------------------------------------------

TEST(Parser, Lights) {
  Scene s = parse(
      "WorldBegin\n"
      "Translate 1 2 3\n"
      "LightSource \"point\" \"rgb I\" [1 2 3] \"float scale\" 2 \"point3 from\" [1 0 0]\n"
      "LightSource \"spot\" \"point3 from\" [0 0 0] \"point3 to\" [0 -1 0] \"float coneangle\" 20\n"
      "Rotate 90 0 0 1\n"
      "LightSource \"distant\" \"rgb L\" [3 3 3] \"point3 from\" [1 0 0] \"point3 to\" [0 0 0]\n"
      "LightSource \"infinite\" \"rgb L\" [0.5 0.6 0.7] \"float scale\" 2\n"
      "LightSource \"point\"\n");
  ASSERT_EQ(s.lights.size(), 5u);
  using K = basalt::Light::Kind;
  const basalt::Light &point = s.lights[0], &spot = s.lights[1], &dist = s.lights[2],
                      &inf = s.lights[3], &def = s.lights[4];
  EXPECT_EQ(point.kind, K::Point);
  EXPECT_EQ(point.value, glm::vec3(2, 4, 6));
  expect_vec_near(point.from, glm::vec3(2, 2, 3));  // CTM * from
  EXPECT_EQ(point.loc.str(), "t.pbrt:3:1");
  EXPECT_EQ(spot.kind, K::Spot);
  EXPECT_EQ(spot.value, glm::vec3(1));
  expect_vec_near(spot.from, glm::vec3(1, 2, 3));
  expect_vec_near(spot.dir, glm::vec3(0, -1, 0));
  EXPECT_EQ(spot.cone_angle, 20.0f);
  EXPECT_EQ(spot.cone_delta, 5.0f);
  // Distant: direction towards the light, CTM applied to (from - to) = (1,0,0) rotated to +y.
  EXPECT_EQ(dist.kind, K::Distant);
  EXPECT_EQ(dist.value, glm::vec3(3));
  expect_vec_near(dist.dir, glm::vec3(0, 1, 0));
  EXPECT_EQ(inf.kind, K::Infinite);
  expect_vec_near(inf.value, glm::vec3(1.0f, 1.2f, 1.4f));
  expect_vec_near(def.from, glm::vec3(1, 2, 3));
  EXPECT_EQ(def.value, glm::vec3(1));
  // A scene with only lights is not empty.
  EXPECT_TRUE(s.shapes.empty());
}

TEST(Parser, DistantLightDefaultPointsDownMinusZ) {
  // from (0,0,0) to (0,0,1): light travels along +z, so the direction towards it is -z.
  Scene s = parse("WorldBegin\nLightSource \"distant\"\n");
  expect_vec_near(s.lights[0].dir, glm::vec3(0, 0, -1));
}

// ---- files ---------------------------------------------------------------------------------

TEST(Parser, IncludeIsRelativeToTheIncludingFile) {
  fs::path d = temp_dir("include");
  write_file(d / "main.pbrt",
             "WorldBegin\nInclude \"sub/geom.pbrt\"\nShape \"sphere\" \"float radius\" 3\n");
  // geom.pbrt includes a file next to itself, changes the CTM (Include is textual).
  write_file(d / "sub" / "geom.pbrt", "Include \"more.pbrt\"\nTranslate 0 0 1\n");
  write_file(d / "sub" / "more.pbrt",
             "Shape \"sphere\" \"float radius\" 2\n"
             "Shape \"plymesh\" \"string filename\" \"tri.ply\"\n");
  write_file(d / "sub" / "tri.ply",
             "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
             "property float z\nelement face 1\nproperty list uchar int vertex_indices\n"
             "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n");
  Scene s = load_scene((d / "main.pbrt").string());
  ASSERT_EQ(s.shapes.size(), 3u);
  EXPECT_EQ(s.shapes[0].radius, 2.0f);
  EXPECT_EQ(s.shapes[0].loc.str(), (d / "sub" / "more.pbrt").string() + ":1:1");
  EXPECT_EQ(s.shapes[1].mesh.indices.size(), 3u);
  EXPECT_EQ(s.shapes[2].radius, 3.0f);
  expect_mat_near(s.shapes[2].world_from_object, glm::translate(glm::mat4(1), glm::vec3(0, 0, 1)));
}

TEST(Parser, ImportKeepsGraphicsStateChangesInside) {
  fs::path d = temp_dir("import");
  write_file(d / "part.pbrt",
             "Translate 0 0 1\nMaterial \"diffuse\" \"rgb reflectance\" [0.1 0.1 0.1]\n"
             "Shape \"sphere\"\n");
  Scene s = parse("WorldBegin\nImport \"part.pbrt\"\nShape \"sphere\"\n", d.string());
  ASSERT_EQ(s.shapes.size(), 2u);
  expect_mat_near(s.shapes[0].world_from_object, glm::translate(glm::mat4(1), glm::vec3(0, 0, 1)));
  expect_mat_near(s.shapes[1].world_from_object, glm::mat4(1));
  EXPECT_EQ(s.materials[s.shapes[1].material].params.at("reflectance").value[0], 0.5f);
}

TEST(Parser, FixtureWithEveryDirective) {
  fs::path p = fs::path(BASALT_SOURCE_DIR) / "tests" / "data" / "parser" / "everything.pbrt";
  Scene s = load_scene(p.string());
  EXPECT_TRUE(s.warnings.empty()) << s.warnings[0];
  EXPECT_EQ(s.sampler.seed, 5);  // from Option "seed"
  EXPECT_EQ(s.sampler.spp, 4);
  EXPECT_EQ(s.film.xres, 64);
  EXPECT_EQ(s.film.yres, 48);
  EXPECT_EQ(s.film.filename, "everything.exr");
  EXPECT_EQ(s.filter.type, basalt::Filter::Type::Box);
  EXPECT_EQ(s.integrator.max_depth, 3);
  EXPECT_EQ(s.camera.fov_deg, 40.0f);
  // Scale -1 1 1 before LookAt mirrors camera x: the camera sits at the eye, looks at the
  // origin, and its +x axis points along world -x.
  expect_vec_near(glm::vec3(s.camera.world_from_camera * glm::vec4(0, 0, 0, 1)),
                  glm::vec3(0, 1, -5));
  expect_vec_near(glm::vec3(s.camera.world_from_camera * glm::vec4(0, 0, 1, 0)),
                  glm::normalize(glm::vec3(0, -1, 5)));
  expect_vec_near(glm::vec3(s.camera.world_from_camera * glm::vec4(1, 0, 0, 0)),
                  glm::vec3(-1, 0, 0));

  ASSERT_EQ(s.lights.size(), 4u);
  expect_vec_near(s.lights[1].from, glm::vec3(0, 4, 0));
  expect_vec_near(s.lights[2].dir, glm::vec3(0, -1, 0));
  EXPECT_EQ(s.lights[2].value, glm::vec3(5));
  expect_vec_near(s.lights[3].dir, glm::vec3(0, 1, 0));

  ASSERT_EQ(s.shapes.size(), 5u);
  const basalt::Shape &floor = s.shapes[0], &lamp = s.shapes[1], &red = s.shapes[2],
                      &imported = s.shapes[3], &last = s.shapes[4];
  EXPECT_EQ(floor.mesh.indices, (std::vector<unsigned>{0, 3, 2, 0, 2, 1}));
  EXPECT_EQ(floor.mesh.uv.size(), 4u);
  EXPECT_EQ(s.materials[floor.material].name, "grey");
  EXPECT_TRUE(lamp.reverse_orientation);
  ASSERT_TRUE(lamp.area_light);
  EXPECT_EQ(lamp.area_light->L, glm::vec3(4));
  EXPECT_TRUE(lamp.area_light->twosided);
  expect_mat_near(lamp.world_from_object,
                  glm::translate(glm::mat4(1), glm::vec3(0, 3, 0)) *
                      glm::rotate(glm::mat4(1), glm::radians(90.0f), glm::vec3(1, 0, 0)));
  EXPECT_FALSE(red.reverse_orientation);
  EXPECT_FALSE(red.area_light);
  expect_mat_near(red.world_from_object, glm::translate(glm::mat4(1), glm::vec3(1, 0.5f, 0)) *
                                             glm::scale(glm::mat4(1), glm::vec3(0.5f)));
  EXPECT_EQ(s.materials[red.material].params.at("reflectance").value,
            (std::vector<float>{0.7f, 0.2f, 0.2f}));
  expect_mat_near(imported.world_from_object, glm::translate(glm::mat4(1), glm::vec3(0, 0, -1)));
  EXPECT_EQ(s.materials[imported.material].params.at("reflectance").value,
            (std::vector<float>{0.3f, 0.3f, 0.3f}));
  EXPECT_EQ(imported.mesh.N.size(), 4u);
  expect_mat_near(last.world_from_object, glm::mat4(1));
  EXPECT_EQ(s.materials[last.material].name, "grey");
}

TEST(ParserErrors, RecursiveInclude) {
  fs::path d = temp_dir("recursive");
  write_file(d / "self.pbrt", "Include \"self.pbrt\"\n");
  std::string e = error_of("Include \"self.pbrt\"\n", d.string());
  EXPECT_EQ(e, (d / "self.pbrt").string() +
                   ":1:1: error: Include nesting deeper than 64 (recursive Include?)");
}

TEST(Parser, SceneFilesInTheRepositoryParse) {
  // Every scene of scenes/ parses without warnings and flattens into tables; the Igea scene
  // needs ../shared/models beside the checkout (README), and fails the test if it is missing.
  int count = 0;
  for (const auto& e : fs::directory_iterator(fs::path(BASALT_SOURCE_DIR) / "scenes")) {
    if (e.path().extension() != ".pbrt") continue;
    std::string name = e.path().filename().string();
    Scene s = load_scene(e.path().string());
    EXPECT_FALSE(s.shapes.empty()) << name;
    EXPECT_TRUE(s.warnings.empty()) << name << ": " << (s.warnings.empty() ? "" : s.warnings[0]);
    std::vector<std::string> warnings;
    basalt::SceneTables t = basalt::build_tables(s, nullptr, &warnings);
    EXPECT_TRUE(warnings.empty()) << name << ": " << (warnings.empty() ? "" : warnings[0]);
    ++count;
  }
  EXPECT_GE(count, 10);
}

// ---- errors: each with its exact location ----------------------------------------------------

TEST(ParserErrors, UnknownDirective) {
  EXPECT_EQ(error_of("WorldBegin\n  Shape \"sphere\"\n  Frobnicate 1\n"),
            "t.pbrt:3:3: error: unknown directive 'Frobnicate'");
  EXPECT_EQ(error_of("WorldBegin\n\"sphere\"\n"),
            "t.pbrt:2:1: error: expected a directive, got \"sphere\"");
}

TEST(ParserErrors, WrongParameterType) {
  EXPECT_EQ(error_of("Camera \"perspective\" \"string fov\" \"wide\"\n" + std::string(kSphere)),
            "t.pbrt:1:22: error: parameter \"fov\" has type string; expected float");
  EXPECT_EQ(
      error_of("WorldBegin\nMaterial \"diffuse\" \"float reflectance\" \"red\"\n"),
      "t.pbrt:2:20: error: parameter \"reflectance\" of type float expects numbers, got \"red\"");
  EXPECT_EQ(
      error_of("Film \"rgb\" \"integer xresolution\" 1.5\n" + std::string(kSphere)),
      "t.pbrt:1:12: error: parameter \"xresolution\" of type integer expects integers, got 1.5");
  EXPECT_EQ(
      error_of("Integrator \"path\" \"bool regularize\" 1\n" + std::string(kSphere)),
      "t.pbrt:1:19: error: parameter \"regularize\" of type bool expects true or false, got 1");
  EXPECT_EQ(error_of("Integrator \"path\" \"quaternion q\" 1\n" + std::string(kSphere)),
            "t.pbrt:1:19: error: unknown parameter type \"quaternion\" for parameter \"q\"");
  // pbrt-v4 DiffuseMaterial takes a spectrum texture: a float reflectance is refused.
  EXPECT_EQ(
      error_of("WorldBegin\nMaterial \"diffuse\" \"float reflectance\" 0.5\n"),
      "t.pbrt:2:20: error: parameter \"reflectance\" has type float; expected rgb or spectrum "
      "or blackbody");
}

TEST(ParserErrors, WrongValueCount) {
  EXPECT_EQ(
      error_of("WorldBegin\nLightSource \"point\" \"point3 from\" [1 2]\n"),
      "t.pbrt:2:21: error: parameter \"from\" of type point3 needs a multiple of 3 values, got 2");
  EXPECT_EQ(error_of("Camera \"perspective\" \"float fov\" [30 40]\n" + std::string(kSphere)),
            "t.pbrt:1:22: error: expected one value for parameter \"fov\", got 2");
  EXPECT_EQ(error_of("Camera \"perspective\" \"float fov\" []\n" + std::string(kSphere)),
            "t.pbrt:1:22: error: no values given for parameter \"fov\"");
  EXPECT_EQ(error_of("Camera \"perspective\" \"float fov\"\n" + std::string(kSphere)),
            "t.pbrt:1:22: error: no value given for parameter \"fov\"");
  EXPECT_EQ(
      error_of("Camera \"perspective\" \"float screenwindow\" [0 1]\n" + std::string(kSphere)),
      "t.pbrt:1:22: error: screenwindow needs four values");
  EXPECT_EQ(error_of("LookAt 0 0 0 1 1\nWorldBegin\n"),
            "t.pbrt:2:1: error: LookAt expects 9 numbers, got WorldBegin");
  EXPECT_EQ(
      error_of("Camera \"perspective\" \"float fov\" [30\nWorldBegin\n"),
      "t.pbrt:2:1: error: unexpected WorldBegin in the values of parameter \"fov\" (missing ']'?)");
}

TEST(ParserErrors, MissingFile) {
  fs::path d = temp_dir("missing");
  std::string top = (d / "nope.pbrt").string();
  try {
    load_scene(top);
    FAIL() << "no error";
  } catch (const SceneError& e) {
    EXPECT_EQ(std::string(e.what()),
              top + ": error: cannot read scene file \"" + top + "\": No such file or directory");
    EXPECT_EQ(e.loc.file, top);
  }
  EXPECT_EQ(error_of("WorldBegin\n  Include \"gone.pbrt\"\n", d.string()),
            "t.pbrt:2:3: error: cannot read included file \"" + (d / "gone.pbrt").string() +
                "\": No such file or directory");
  EXPECT_EQ(
      error_of("WorldBegin\nShape \"plymesh\" \"string filename\" \"gone.ply\"\n", d.string()),
      "t.pbrt:2:1: error: PLY file \"" + (d / "gone.ply").string() +
          "\": cannot read PLY file: No such file or directory");
}

TEST(ParserErrors, UnreadableFile) {
  // chmod 000 does not stop root: a directory is a file name that cannot be read.
  fs::path d = temp_dir("unreadable");
  fs::create_directories(d / "dir.pbrt");
  std::string top = (d / "dir.pbrt").string();
  try {
    load_scene(top);
    FAIL() << "no error";
  } catch (const SceneError& e) {
    EXPECT_EQ(std::string(e.what()),
              top + ": error: cannot read scene file \"" + top + "\": is a directory");
  }
  EXPECT_EQ(error_of("Include \"dir.pbrt\"\n", d.string()),
            "t.pbrt:1:1: error: cannot read included file \"" + top + "\": is a directory");
}

TEST(ParserErrors, UnterminatedString) {
  EXPECT_EQ(error_of("WorldBegin\nShape \"sphere\n\"float radius\" 1\n"),
            "t.pbrt:2:7: error: unterminated string");
  EXPECT_EQ(error_of("WorldBegin\nShape \"sphere"), "t.pbrt:2:7: error: unterminated string");
}

TEST(ParserErrors, MalformedNumber) {
  EXPECT_EQ(error_of("WorldBegin\nTranslate 1.2.3 0 0\n"),
            "t.pbrt:2:11: error: malformed number '1.2.3'");
  EXPECT_EQ(error_of("WorldBegin\nTranslate 1 1e 0\n"),
            "t.pbrt:2:13: error: malformed number '1e'");
  EXPECT_EQ(error_of("WorldBegin\nShape \"sphere\" \"float radius\" [ - ]\n"),
            "t.pbrt:2:33: error: malformed number '-'");
}

TEST(ParserErrors, BadResolution) {
  EXPECT_EQ(error_of("Film \"rgb\"\n  \"integer xresolution\" [ -640 ]\n" + std::string(kSphere)),
            "t.pbrt:2:3: error: xresolution must be positive, got -640");
  EXPECT_EQ(error_of("Film \"rgb\" \"integer xresolution\" 4 \"integer yresolution\" 0\n" +
                     std::string(kSphere)),
            "t.pbrt:1:36: error: yresolution must be positive, got 0");
}

TEST(ParserErrors, EmptyScene) {
  EXPECT_EQ(error_of(""), "t.pbrt:1:1: error: empty scene: no shapes or lights (no WorldBegin)");
  EXPECT_EQ(error_of("# nothing\nCamera \"perspective\"\nWorldBegin\n"),
            "t.pbrt:4:1: error: empty scene: no shapes or lights");
}

TEST(ParserErrors, UnsupportedMaterial) {
  EXPECT_EQ(error_of("WorldBegin\n  Material \"hair\"\nShape \"sphere\"\n"),
            "t.pbrt:2:3: error: material 'hair' is not supported by basalt");
  EXPECT_EQ(error_of("WorldBegin\nMakeNamedMaterial \"m\" \"string type\" \"subsurface\"\n"),
            "t.pbrt:2:23: error: material 'subsurface' is not supported by basalt");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"velvet\"\n"),
            "t.pbrt:2:1: error: unknown material type 'velvet'");
  EXPECT_EQ(error_of("WorldBegin\nMakeNamedMaterial \"m\" \"rgb reflectance\" [1 1 1]\n"),
            "t.pbrt:2:1: error: MakeNamedMaterial \"m\" needs a \"string type\" parameter");
  EXPECT_EQ(error_of("WorldBegin\nMakeNamedMaterial \"m\" \"string type\" \"diffuse\"\n"
                     "MakeNamedMaterial \"m\" \"string type\" \"diffuse\"\n"),
            "t.pbrt:3:1: error: named material \"m\" redefined");
  EXPECT_EQ(error_of("WorldBegin\n NamedMaterial \"nope\"\nShape \"sphere\"\n"),
            "t.pbrt:2:2: error: named material \"nope\" is not defined");
  EXPECT_EQ(
      error_of("WorldBegin\nMaterial \"diffuse\" \"rgb reflectance\" [1.5 0 0]\n"),
      "t.pbrt:2:20: error: parameter \"reflectance\" is a reflectance and has a component above 1");
}

TEST(ParserErrors, UnbalancedAttributes) {
  EXPECT_EQ(error_of("WorldBegin\nShape \"sphere\"\n  AttributeEnd\n"),
            "t.pbrt:3:3: error: AttributeEnd without a matching AttributeBegin");
  EXPECT_EQ(
      error_of("WorldBegin\nAttributeBegin\n AttributeBegin\nAttributeEnd\nShape \"sphere\"\n"),
      "t.pbrt:2:1: error: AttributeBegin without a matching AttributeEnd");
  EXPECT_EQ(error_of("AttributeBegin\n"),
            "t.pbrt:1:1: error: 'AttributeBegin' is only allowed after WorldBegin");
}

TEST(ParserErrors, BlockStructure) {
  EXPECT_EQ(error_of("Shape \"sphere\"\n"),
            "t.pbrt:1:1: error: 'Shape' is only allowed after WorldBegin");
  EXPECT_EQ(error_of("WorldBegin\nShape \"sphere\"\nCamera \"perspective\"\n"),
            "t.pbrt:3:1: error: 'Camera' is not allowed after WorldBegin");
  EXPECT_EQ(error_of("WorldBegin\nWorldBegin\n"),
            "t.pbrt:2:1: error: 'WorldBegin' is not allowed after WorldBegin");
}

TEST(ParserErrors, UnsupportedTypesAreNamed) {
  EXPECT_EQ(error_of("Camera \"orthographic\"\n" + std::string(kSphere)),
            "t.pbrt:1:1: error: camera 'orthographic' is not supported yet (basalt has the "
            "perspective camera)");
  EXPECT_EQ(error_of("WorldBegin\nShape \"cylinder\"\n"),
            "t.pbrt:2:1: error: shape 'cylinder' is not supported yet");
  EXPECT_EQ(error_of("WorldBegin\nLightSource \"goniometric\"\n"),
            "t.pbrt:2:1: error: light 'goniometric' is not supported yet");
  EXPECT_EQ(error_of("WorldBegin\nAreaLightSource \"fancy\"\n"),
            "t.pbrt:2:1: error: area light 'fancy' is not supported yet");
  EXPECT_EQ(error_of("PixelFilter \"mitchell\"\n" + std::string(kSphere)),
            "t.pbrt:1:1: error: filter 'mitchell' is not supported yet (box and gaussian are)");
  EXPECT_EQ(error_of("Integrator \"bdpt\"\n" + std::string(kSphere)),
            "t.pbrt:1:1: error: integrator 'bdpt' is not supported (basalt renders with "
            "Integrator 'path')");
  EXPECT_EQ(error_of("Film \"fancy\"\n" + std::string(kSphere)),
            "t.pbrt:1:1: error: film 'fancy' is not supported (basalt writes Film 'rgb')");
  EXPECT_EQ(error_of("WorldBegin\n Texture \"t\" \"spectrum\" \"ptex\"\n"),
            "t.pbrt:2:25: error: ptex textures are not supported (texture \"t\")");
  EXPECT_EQ(error_of("WorldBegin\n Texture \"t\" \"spectrum\" \"fancy\"\n"),
            "t.pbrt:2:25: error: unknown texture class \"fancy\"");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"diffuse\" \"texture reflectance\" \"t\"\n"),
            "t.pbrt:2:20: error: parameter \"reflectance\": spectrum texture \"t\" is not defined");
  // pbrt-v4's regularisation is refused where it is asked for, never ignored.
  EXPECT_EQ(error_of("Integrator \"path\" \"bool regularize\" true\n" + std::string(kSphere)),
            "t.pbrt:1:19: error: \"regularize\" true is not supported (basalt does not "
            "regularize BSDFs)");
  EXPECT_EQ(error_of("Film \"rgb\" \"float maxcomponentvalue\" 10\n" + std::string(kSphere)),
            "t.pbrt:1:12: error: \"maxcomponentvalue\" is not supported (basalt does not clamp "
            "samples; remove it or set it to infinity)");
  EXPECT_EQ(error_of("WorldBegin\nLightSource \"infinite\" \"point3 portal\" "
                     "[ 0 0 0  1 0 0  1 1 0 ]\n"),
            "t.pbrt:2:24: error: expected 4 vertices for infinite light \"portal\" but given 3");
  EXPECT_EQ(error_of("WorldBegin\nLightSource \"point\" \"spectrum I\" \"stdillum-D65\"\n"),
            "t.pbrt:2:21: error: unknown named spectrum \"stdillum-D65\" for parameter \"I\" "
            "(basalt knows metal-Ag-eta, metal-Ag-k, metal-Al-eta, metal-Al-k, metal-Au-eta, "
            "metal-Au-k, metal-Cu-eta, metal-Cu-k, metal-CuZn-eta, metal-CuZn-k, metal-MgO-eta, "
            "metal-MgO-k, metal-TiO2-eta, metal-TiO2-k, glass-BK7, glass-BAF10, glass-FK51A, "
            "glass-LASF9, glass-F5, glass-F10, glass-F11)");
  EXPECT_EQ(
      error_of("WorldBegin\nLightSource \"point\" \"float power\" 10\n"),
      "t.pbrt:2:21: error: parameter \"power\" (photometric light scaling) is not supported yet");
}

TEST(ParserErrors, PartialSphere) {
  EXPECT_EQ(error_of("WorldBegin\nShape \"sphere\" \"float zmax\" 0.5\n"),
            "t.pbrt:2:16: error: partial spheres not supported");
  EXPECT_EQ(error_of("WorldBegin\nShape \"sphere\" \"float radius\" 2 \"float phimax\" 180\n"),
            "t.pbrt:2:33: error: partial spheres not supported");
  // zmin/zmax beyond the radius are clamped (pbrt-v4 Sphere): still a full sphere.
  EXPECT_EQ(error_of("WorldBegin\nShape \"sphere\" \"float zmin\" -5 \"float zmax\" 5\n"), "");
}

TEST(ParserErrors, BadTriangleMesh) {
  EXPECT_EQ(error_of("WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"
                     "  \"integer indices\" [0 1 3]\n"),
            "t.pbrt:3:3: error: trianglemesh index 3 out of range (the mesh has 3 vertices)");
  EXPECT_EQ(error_of("WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"
                     "  \"integer indices\" [0 1]\n"),
            "t.pbrt:3:3: error: trianglemesh has 2 indices, not a multiple of 3");
  EXPECT_EQ(error_of("WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0 1 1 1]\n"),
            "t.pbrt:2:1: error: trianglemesh needs \"integer indices\" (only a mesh of exactly 3 "
            "vertices may omit them; this one has 4)");
  EXPECT_EQ(error_of("WorldBegin\nShape \"trianglemesh\" \"integer indices\" [0 1 2]\n"),
            "t.pbrt:2:1: error: trianglemesh needs vertex positions \"point3 P\"");
  EXPECT_EQ(error_of("WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"
                     "  \"normal N\" [0 0 1]\n"),
            "t.pbrt:3:3: error: trianglemesh has 1 normals \"N\" for 3 vertices");
  EXPECT_EQ(error_of("WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0]\n"
                     "  \"point2 uv\" [0 0]\n"),
            "t.pbrt:3:3: error: trianglemesh has 1 \"uv\" values for 3 vertices");
}

TEST(ParserErrors, DegenerateTransforms) {
  EXPECT_EQ(error_of("LookAt 0 0 0  0 0 1  0 0 1\n" + std::string(kSphere)),
            "t.pbrt:1:1: error: LookAt up vector and viewing direction are parallel");
  EXPECT_EQ(error_of("Scale 0 1 1\nCamera \"perspective\"\n" + std::string(kSphere)),
            "t.pbrt:2:1: error: the camera transform (CTM at Camera) is not invertible");
  EXPECT_EQ(error_of("WorldBegin\nRotate 10 0 0 0\n"),
            "t.pbrt:2:1: error: Rotate axis is the zero vector");
}

// ---- materials (docs/materials.md): names, defaults, slots, flags, mixes, spectra, MERL -------

namespace {

using namespace basalt::gpu;
using basalt::MixMode;

// The GPU material that shape 0 of the parsed scene uses (scene text after WorldBegin).
basalt::gpu::Material material_of(const std::string& world, MixMode mode = MixMode::Auto,
                                  const std::string& base_dir = ".") {
  Scene s = load_scene_from_string("WorldBegin\n" + world + "\nShape \"sphere\"\n", "t.pbrt",
                                   base_dir, mode);
  basalt::SceneTables t = basalt::build_tables(s);
  return t.materials.at(std::size_t(s.shapes.at(0).material));
}

// Slot i's rgb.
glm::vec3 slot(const basalt::gpu::Material& m, std::uint32_t i) { return glm::vec3(m.value[i]); }

// The reflectance-rule rgb of a named spectrum.
glm::vec3 named(const char* name) {
  return glm::vec3(basalt::spectrum_to_rgb_reflectance(*basalt::named_spectrum(name)));
}

}  // namespace

TEST(Materials, EveryPbrtV4NameWithDefaults) {
  const glm::vec3 cu_eta = named("metal-Cu-eta"), cu_k = named("metal-Cu-k");
  auto m = material_of("Material \"diffuse\"");
  EXPECT_EQ(m.type, MATERIAL_DIFFUSE);
  EXPECT_EQ(slot(m, SLOT_DIFFUSE_REFLECTANCE), glm::vec3(0.5f));

  m = material_of("Material \"coateddiffuse\"");
  EXPECT_EQ(m.type, MATERIAL_COATED_DIFFUSE);
  EXPECT_EQ(m.flags, MATFLAG_REMAP_SQRT);
  EXPECT_EQ(slot(m, SLOT_CD_REFLECTANCE), glm::vec3(0.5f));
  EXPECT_EQ(m.value[SLOT_CD_UROUGH].x, 0.0f);
  EXPECT_EQ(m.value[SLOT_CD_VROUGH].x, 0.0f);
  EXPECT_EQ(m.value[SLOT_CD_THICKNESS].x, 0.01f);
  EXPECT_EQ(m.value[SLOT_CD_ETA].x, 1.5f);
  EXPECT_EQ(slot(m, SLOT_CD_ALBEDO), glm::vec3(0.0f));
  EXPECT_EQ(m.value[SLOT_CD_G].x, 0.0f);
  EXPECT_EQ(m.aux0, 10u);  // maxdepth
  EXPECT_EQ(m.aux1, 1u);   // nsamples

  m = material_of("Material \"coatedconductor\"");
  EXPECT_EQ(m.type, MATERIAL_COATED_CONDUCTOR);
  EXPECT_EQ(m.flags, MATFLAG_REMAP_SQRT);
  EXPECT_EQ(m.value[SLOT_CC_IF_UROUGH].x, 0.0f);
  EXPECT_EQ(m.value[SLOT_CC_THICKNESS].x, 0.01f);
  EXPECT_EQ(m.value[SLOT_CC_IF_ETA].x, 1.5f);
  EXPECT_EQ(m.value[SLOT_CC_G].x, 0.0f);
  EXPECT_EQ(slot(m, SLOT_CC_ALBEDO), glm::vec3(0.0f));
  EXPECT_EQ(m.value[SLOT_CC_UROUGH].x, 0.0f);
  EXPECT_EQ(slot(m, SLOT_CC_ETA), cu_eta);
  EXPECT_EQ(slot(m, SLOT_CC_K), cu_k);
  EXPECT_EQ(m.aux0, 10u);
  EXPECT_EQ(m.aux1, 1u);

  m = material_of("Material \"conductor\"");
  EXPECT_EQ(m.type, MATERIAL_CONDUCTOR);
  EXPECT_EQ(m.flags, MATFLAG_REMAP_SQRT);
  EXPECT_EQ(slot(m, SLOT_CONDUCTOR_ETA), cu_eta);
  EXPECT_EQ(slot(m, SLOT_CONDUCTOR_K), cu_k);
  EXPECT_EQ(m.value[SLOT_CONDUCTOR_UROUGH].x, 0.0f);
  EXPECT_EQ(m.value[SLOT_CONDUCTOR_VROUGH].x, 0.0f);

  m = material_of("Material \"dielectric\"");
  EXPECT_EQ(m.type, MATERIAL_DIELECTRIC);
  EXPECT_EQ(m.flags, MATFLAG_REMAP_SQRT);
  EXPECT_EQ(m.value[SLOT_DIELECTRIC_ETA].x, 1.5f);
  EXPECT_EQ(m.value[SLOT_DIELECTRIC_UROUGH].x, 0.0f);
  EXPECT_EQ(slot(m, SLOT_DIELECTRIC_KR), glm::vec3(1.0f));
  EXPECT_EQ(slot(m, SLOT_DIELECTRIC_KT), glm::vec3(1.0f));

  m = material_of("Material \"thindielectric\"");
  EXPECT_EQ(m.type, MATERIAL_THIN_DIELECTRIC);
  EXPECT_EQ(m.value[SLOT_THIN_ETA].x, 1.5f);

  m = material_of("Material \"diffusetransmission\"");
  EXPECT_EQ(m.type, MATERIAL_DIFFUSE_TRANSMISSION);
  EXPECT_EQ(slot(m, SLOT_DT_REFLECTANCE), glm::vec3(0.25f));
  EXPECT_EQ(slot(m, SLOT_DT_TRANSMITTANCE), glm::vec3(0.25f));
  EXPECT_EQ(m.value[SLOT_DT_SCALE].x, 1.0f);

  m = material_of("Material \"interface\"");
  EXPECT_EQ(m.type, MATERIAL_INTERFACE);
  for (const auto& t : m.texture) EXPECT_EQ(t, glm::uvec4(INVALID_INDEX));
}

TEST(Materials, EveryPbrtV3NameWithDefaults) {
  const glm::vec3 cu_eta = named("metal-Cu-eta"), cu_k = named("metal-Cu-k");
  auto m = material_of("Material \"matte\"");
  EXPECT_EQ(m.type, MATERIAL_OREN_NAYAR);
  EXPECT_EQ(slot(m, SLOT_ON_REFLECTANCE), glm::vec3(0.5f));
  EXPECT_EQ(m.value[SLOT_ON_SIGMA].x, 0.0f);

  m = material_of("Material \"plastic\"");
  EXPECT_EQ(m.type, MATERIAL_PLASTIC);
  EXPECT_EQ(m.flags, MATFLAG_REMAP_V3);
  EXPECT_EQ(slot(m, SLOT_PLASTIC_KD), glm::vec3(0.25f));
  EXPECT_EQ(slot(m, SLOT_PLASTIC_KS), glm::vec3(0.25f));
  EXPECT_EQ(m.value[SLOT_PLASTIC_ROUGH].x, 0.1f);

  m = material_of("Material \"metal\"");
  EXPECT_EQ(m.type, MATERIAL_METAL);
  EXPECT_EQ(m.flags, MATFLAG_REMAP_V3);
  EXPECT_EQ(slot(m, SLOT_CONDUCTOR_ETA), cu_eta);  // pbrt-v3's copper = pbrt-v4 metal-Cu
  EXPECT_EQ(slot(m, SLOT_CONDUCTOR_K), cu_k);
  EXPECT_EQ(m.value[SLOT_CONDUCTOR_UROUGH].x, 0.01f);
  EXPECT_EQ(m.value[SLOT_CONDUCTOR_VROUGH].x, 0.01f);

  m = material_of("Material \"mirror\"");
  EXPECT_EQ(m.type, MATERIAL_MIRROR);
  EXPECT_EQ(slot(m, SLOT_MIRROR_KR), glm::vec3(0.9f));

  m = material_of("Material \"glass\"");
  EXPECT_EQ(m.type, MATERIAL_DIELECTRIC);
  EXPECT_EQ(m.flags, MATFLAG_REMAP_NONE);  // roughness 0 is specular in pbrt-v3 glass
  EXPECT_EQ(m.value[SLOT_DIELECTRIC_ETA].x, 1.5f);
  EXPECT_EQ(slot(m, SLOT_DIELECTRIC_KR), glm::vec3(1.0f));
  EXPECT_EQ(slot(m, SLOT_DIELECTRIC_KT), glm::vec3(1.0f));

  m = material_of("Material \"substrate\"");
  EXPECT_EQ(m.type, MATERIAL_SUBSTRATE);
  EXPECT_EQ(m.flags, MATFLAG_REMAP_V3);
  EXPECT_EQ(slot(m, SLOT_SUBSTRATE_KD), glm::vec3(0.5f));
  EXPECT_EQ(slot(m, SLOT_SUBSTRATE_KS), glm::vec3(0.5f));
  EXPECT_EQ(m.value[SLOT_SUBSTRATE_UROUGH].x, 0.1f);
  EXPECT_EQ(m.value[SLOT_SUBSTRATE_VROUGH].x, 0.1f);

  m = material_of("Material \"translucent\"");
  EXPECT_EQ(m.type, MATERIAL_TRANSLUCENT);
  EXPECT_EQ(slot(m, SLOT_TRANSLUCENT_KD), glm::vec3(0.25f));
  EXPECT_EQ(slot(m, SLOT_TRANSLUCENT_KS), glm::vec3(0.25f));
  EXPECT_EQ(slot(m, SLOT_TRANSLUCENT_REFLECT), glm::vec3(0.5f));
  EXPECT_EQ(slot(m, SLOT_TRANSLUCENT_TRANSMIT), glm::vec3(0.5f));
  EXPECT_EQ(m.value[SLOT_TRANSLUCENT_ROUGH].x, 0.1f);

  m = material_of("Material \"uber\"");
  EXPECT_EQ(m.type, MATERIAL_UBER);
  EXPECT_EQ(slot(m, SLOT_UBER_KD), glm::vec3(0.25f));
  EXPECT_EQ(slot(m, SLOT_UBER_KS), glm::vec3(0.25f));
  EXPECT_EQ(slot(m, SLOT_UBER_KR), glm::vec3(0.0f));
  EXPECT_EQ(slot(m, SLOT_UBER_KT), glm::vec3(0.0f));
  EXPECT_EQ(m.value[SLOT_UBER_UROUGH].x, 0.1f);
  EXPECT_EQ(m.value[SLOT_UBER_VROUGH].x, 0.1f);
  EXPECT_EQ(m.value[SLOT_UBER_ETA].x, 1.5f);
  EXPECT_EQ(slot(m, SLOT_UBER_OPACITY), glm::vec3(1.0f));
}

TEST(Materials, ParametersReachTheirSlots) {
  auto m = material_of(
      "Material \"coatedconductor\" \"float interface.uroughness\" 0.1 "
      "\"float interface.vroughness\" 0.2 \"float thickness\" 0.3 \"float interface.eta\" 1.7 "
      "\"float g\" -0.4 \"rgb albedo\" [0.1 0.2 0.3] \"float conductor.roughness\" 0.5 "
      "\"rgb conductor.eta\" [1 2 3] \"rgb conductor.k\" [4 5 6] \"integer maxdepth\" 3 "
      "\"integer nsamples\" 2 \"bool remaproughness\" false");
  EXPECT_EQ(m.flags, MATFLAG_REMAP_NONE);
  EXPECT_EQ(m.value[SLOT_CC_IF_UROUGH].x, 0.1f);
  EXPECT_EQ(m.value[SLOT_CC_IF_VROUGH].x, 0.2f);
  EXPECT_EQ(m.value[SLOT_CC_THICKNESS].x, 0.3f);
  EXPECT_EQ(m.value[SLOT_CC_IF_ETA].x, 1.7f);
  EXPECT_EQ(m.value[SLOT_CC_G].x, -0.4f);
  EXPECT_EQ(slot(m, SLOT_CC_ALBEDO), glm::vec3(0.1f, 0.2f, 0.3f));
  EXPECT_EQ(m.value[SLOT_CC_UROUGH].x, 0.5f);  // conductor.roughness sets both
  EXPECT_EQ(m.value[SLOT_CC_VROUGH].x, 0.5f);
  EXPECT_EQ(slot(m, SLOT_CC_ETA), glm::vec3(1, 2, 3));
  EXPECT_EQ(slot(m, SLOT_CC_K), glm::vec3(4, 5, 6));
  EXPECT_EQ(m.aux0, 3u);
  EXPECT_EQ(m.aux1, 2u);

  m = material_of("Material \"conductor\" \"rgb reflectance\" [0.9 0.5 0.2] "
                  "\"float uroughness\" 0.1 \"float roughness\" 0.3");
  EXPECT_EQ(m.flags, MATFLAG_REMAP_SQRT | MATFLAG_USE_REFLECTANCE);
  EXPECT_EQ(slot(m, SLOT_CONDUCTOR_REFLECTANCE), glm::vec3(0.9f, 0.5f, 0.2f));
  EXPECT_EQ(m.value[SLOT_CONDUCTOR_UROUGH].x, 0.1f);  // uroughness wins over roughness
  EXPECT_EQ(m.value[SLOT_CONDUCTOR_VROUGH].x, 0.3f);

  m = material_of("Material \"uber\" \"rgb Kd\" [0.1 0.2 0.3] \"rgb Ks\" [0.4 0.5 0.6] "
                  "\"rgb Kr\" [0.7 0.8 0.9] \"rgb Kt\" [0.2 0.2 0.2] \"float roughness\" 0.3 "
                  "\"float vroughness\" 0.4 \"float index\" 1.33 \"rgb opacity\" [0.5 0.6 0.7]");
  EXPECT_EQ(slot(m, SLOT_UBER_KD), glm::vec3(0.1f, 0.2f, 0.3f));
  EXPECT_EQ(slot(m, SLOT_UBER_KS), glm::vec3(0.4f, 0.5f, 0.6f));
  EXPECT_EQ(slot(m, SLOT_UBER_KR), glm::vec3(0.7f, 0.8f, 0.9f));
  EXPECT_EQ(slot(m, SLOT_UBER_KT), glm::vec3(0.2f));
  EXPECT_EQ(m.value[SLOT_UBER_UROUGH].x, 0.3f);
  EXPECT_EQ(m.value[SLOT_UBER_VROUGH].x, 0.4f);
  EXPECT_EQ(m.value[SLOT_UBER_ETA].x, 1.33f);
  EXPECT_EQ(slot(m, SLOT_UBER_OPACITY), glm::vec3(0.5f, 0.6f, 0.7f));

  m = material_of("Material \"glass\" \"float eta\" 1.7 \"float index\" 1.2 "
                  "\"float uroughness\" 0.2 \"rgb Kt\" [0.5 0.6 0.7]");
  EXPECT_EQ(m.value[SLOT_DIELECTRIC_ETA].x, 1.7f);  // eta wins over index
  EXPECT_EQ(m.flags, MATFLAG_REMAP_V3);
  EXPECT_EQ(slot(m, SLOT_DIELECTRIC_KT), glm::vec3(0.5f, 0.6f, 0.7f));

  m = material_of("Material \"matte\" \"rgb Kd\" [0.2 0.3 0.4] \"float sigma\" 20");
  EXPECT_EQ(slot(m, SLOT_ON_REFLECTANCE), glm::vec3(0.2f, 0.3f, 0.4f));
  EXPECT_EQ(m.value[SLOT_ON_SIGMA].x, 20.0f);

  m = material_of("Material \"translucent\" \"rgb reflect\" [0.1 0.2 0.3] "
                  "\"rgb transmit\" [0.4 0.5 0.6] \"float roughness\" 0.2");
  EXPECT_EQ(slot(m, SLOT_TRANSLUCENT_REFLECT), glm::vec3(0.1f, 0.2f, 0.3f));
  EXPECT_EQ(slot(m, SLOT_TRANSLUCENT_TRANSMIT), glm::vec3(0.4f, 0.5f, 0.6f));
  EXPECT_EQ(m.value[SLOT_TRANSLUCENT_ROUGH].x, 0.2f);

  m = material_of("Material \"diffusetransmission\" \"rgb transmittance\" [0.1 0.2 0.3] "
                  "\"float scale\" 0.5 \"float sigma\" 10");
  EXPECT_EQ(slot(m, SLOT_DT_TRANSMITTANCE), glm::vec3(0.1f, 0.2f, 0.3f));
  EXPECT_EQ(m.value[SLOT_DT_SCALE].x, 0.5f);
}

TEST(Materials, RoughnessRemapAndDistribution) {
  EXPECT_EQ(material_of("Material \"dielectric\" \"bool remaproughness\" false").flags,
            MATFLAG_REMAP_NONE);
  EXPECT_EQ(material_of("Material \"plastic\" \"bool remaproughness\" false").flags,
            MATFLAG_REMAP_NONE);
  EXPECT_EQ(material_of("Material \"metal\" \"string distribution\" \"beckmann\"").flags,
            MATFLAG_REMAP_V3 | MATFLAG_BECKMANN);
  EXPECT_EQ(material_of("Material \"substrate\" \"string distribution\" \"trowbridgereitz\"").flags,
            MATFLAG_REMAP_V3);
  EXPECT_EQ(material_of("Material \"glass\" \"string distribution\" \"beckmann\"").flags,
            MATFLAG_BECKMANN);  // zero roughness: no remap
  auto m = material_of("Material \"substrate\" \"float roughness\" 0.3");
  EXPECT_EQ(m.value[SLOT_SUBSTRATE_UROUGH].x, 0.3f);
  EXPECT_EQ(m.value[SLOT_SUBSTRATE_VROUGH].x, 0.3f);
  // The distribution extension is for pbrt-v3 names only: unused (a warning) on pbrt-v4 names.
  Scene s = parse("WorldBegin\nMaterial \"conductor\" \"string distribution\" \"beckmann\"\n"
                  "Shape \"sphere\"\n");
  EXPECT_TRUE(has_warning(s, "t.pbrt:2:22: warning: unused parameter \"string distribution\" for "
                             "Material 'conductor' (not supported by basalt; ignored)"));
}

TEST(Materials, InterfaceSpellingsAndFeatureBits) {
  Scene s = parse("WorldBegin\nMaterial \"\"\nShape \"sphere\"\nMaterial \"none\"\n"
                  "Shape \"sphere\"\n");
  EXPECT_TRUE(has_warning(
      s, "t.pbrt:2:1: warning: material \"\" is deprecated; use \"interface\" (pbrt-v4)"));
  EXPECT_TRUE(has_warning(
      s, "t.pbrt:4:1: warning: material \"none\" is deprecated; use \"interface\" (pbrt-v4)"));
  basalt::SceneTables t = basalt::build_tables(s);
  EXPECT_EQ(t.materials[0].type, MATERIAL_INTERFACE);
  EXPECT_EQ(t.materials[1].type, MATERIAL_INTERFACE);
  EXPECT_EQ(t.features & (FEATURE_MAT_INTERFACE | FEATURE_MAT_DIFFUSE), FEATURE_MAT_INTERFACE);

  // Each kind sets its own feature bit (and only kinds present are set).
  struct Case {
    const char* material;
    std::uint32_t bit;
  } cases[] = {{"diffuse", FEATURE_MAT_DIFFUSE},
               {"matte", FEATURE_MAT_OREN_NAYAR},
               {"conductor", FEATURE_MAT_CONDUCTOR},
               {"dielectric", FEATURE_MAT_DIELECTRIC},
               {"glass", FEATURE_MAT_DIELECTRIC},
               {"thindielectric", FEATURE_MAT_THIN_DIELECTRIC},
               {"diffusetransmission", FEATURE_MAT_DIFFUSE_TRANSMISSION},
               {"coateddiffuse", FEATURE_MAT_COATED_DIFFUSE},
               {"coatedconductor", FEATURE_MAT_COATED_CONDUCTOR},
               {"plastic", FEATURE_MAT_PLASTIC},
               {"substrate", FEATURE_MAT_SUBSTRATE},
               {"translucent", FEATURE_MAT_TRANSLUCENT},
               {"uber", FEATURE_MAT_UBER},
               {"interface", FEATURE_MAT_INTERFACE},
               {"mirror", FEATURE_MAT_MIRROR},
               {"metal", FEATURE_MAT_METAL}};
  std::uint32_t all_mats = 0;
  for (std::uint32_t b = 7; b < FEATURE_COUNT; ++b)
    if (b == 7 || b >= 11) all_mats |= 1u << b;
  for (const Case& c : cases) {
    Scene one = parse(std::string("WorldBegin\nMaterial \"") + c.material + "\"\nShape \"sphere\"\n");
    EXPECT_EQ(basalt::build_tables(one).features & all_mats, c.bit) << c.material;
  }
}

TEST(Materials, MixSemantics) {
  const std::string defs =
      "MakeNamedMaterial \"a\" \"string type\" \"diffuse\"\n"
      "MakeNamedMaterial \"b\" \"string type\" \"conductor\"\n";
  // pbrt-v4 syntax: stochastic; materials[1] gets amount -> aux1.
  std::string v4 = defs + "Material \"mix\" \"string materials\" [\"a\" \"b\"] \"float amount\" 0.3";
  Scene s = parse("WorldBegin\n" + v4 + "\nShape \"sphere\"\n");
  basalt::SceneTables t = basalt::build_tables(s);
  const auto& m = t.materials[std::size_t(s.shapes[0].material)];
  EXPECT_EQ(m.type, MATERIAL_MIX);
  EXPECT_EQ(m.aux0, 0u);
  EXPECT_EQ(m.aux1, 1u);
  EXPECT_EQ(m.value[SLOT_MIX_AMOUNT].x, 0.3f);
  EXPECT_TRUE(t.features & FEATURE_MAT_MIX);
  EXPECT_FALSE(t.features & FEATURE_MAT_MIX_WEIGHTED);
  EXPECT_EQ(material_of(v4, MixMode::Weighted).type, MATERIAL_MIX_WEIGHTED);
  EXPECT_EQ(material_of(v4, MixMode::Stochastic).type, MATERIAL_MIX);
  EXPECT_EQ(material_of(defs + "Material \"mix\" \"string materials\" [\"a\" \"b\"]")
                .value[SLOT_MIX_AMOUNT]
                .x,
            0.5f);

  // pbrt-v3 syntax: weighted; namedmaterial1 is scaled by amount -> aux1.
  std::string v3 = defs + "Material \"mix\" \"string namedmaterial1\" \"a\" "
                          "\"string namedmaterial2\" \"b\" \"rgb amount\" [0.2 0.4 0.6]";
  auto w = material_of(v3);
  EXPECT_EQ(w.type, MATERIAL_MIX_WEIGHTED);
  EXPECT_EQ(w.aux1, 0u);  // "a"
  EXPECT_EQ(w.aux0, 1u);  // "b"
  EXPECT_EQ(slot(w, SLOT_MIX_AMOUNT), glm::vec3(0.2f, 0.4f, 0.6f));
  EXPECT_EQ(material_of(v3, MixMode::Weighted).type, MATERIAL_MIX_WEIGHTED);
  // Forced stochastic: one probability, the mean of the rgb amount (with a warning).
  Scene sv3 = load_scene_from_string("WorldBegin\n" + v3 + "\nShape \"sphere\"\n", "t.pbrt", ".",
                                     MixMode::Stochastic);
  EXPECT_EQ(sv3.mix_mode, MixMode::Stochastic);
  std::vector<std::string> warnings;
  t = basalt::build_tables(sv3, nullptr, &warnings);
  const auto& st = t.materials[std::size_t(sv3.shapes[0].material)];
  EXPECT_EQ(st.type, MATERIAL_MIX);
  EXPECT_NEAR(st.value[SLOT_MIX_AMOUNT].x, 0.4f, 1e-6f);
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_EQ(warnings[0].rfind("t.pbrt:4:1: warning: a 'mix' material: rgb amount", 0), 0u)
      << warnings[0];
  EXPECT_EQ(material_of(defs + "Material \"mix\" \"string namedmaterial1\" \"a\" "
                               "\"string namedmaterial2\" \"b\"")
                .value[SLOT_MIX_AMOUNT],
            glm::vec4(0.5f, 0.5f, 0.5f, 0.0f));

  // Names may be defined after the mix (resolved at the end, as pbrt-v4 does); nesting and
  // interfaces are fine in stochastic mixes.
  Scene late = parse(
      "WorldBegin\nMakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" "
      "[\"x\" \"y\"]\nNamedMaterial \"m\"\nShape \"sphere\"\n"
      "MakeNamedMaterial \"x\" \"string type\" \"interface\"\n"
      "MakeNamedMaterial \"y\" \"string type\" \"mix\" \"string materials\" [\"x\" \"z\"]\n"
      "MakeNamedMaterial \"z\" \"string type\" \"diffuse\"\n");
  t = basalt::build_tables(late);
  EXPECT_EQ(t.materials[0].type, MATERIAL_MIX);
  EXPECT_EQ(t.materials[t.materials[0].aux1].type, MATERIAL_MIX);
}

TEST(MaterialErrors, LocatedMessages) {
  const std::string defs =
      "WorldBegin\nMakeNamedMaterial \"a\" \"string type\" \"diffuse\"\n"
      "MakeNamedMaterial \"u\" \"string type\" \"uber\"\n"
      "MakeNamedMaterial \"t\" \"string type\" \"translucent\"\n"
      "MakeNamedMaterial \"i\" \"string type\" \"interface\"\n";  // materials end on line 5
  EXPECT_EQ(error_of(defs + "Material \"mix\" \"string materials\" [\"a\" \"nope\"]\n" + "Shape \"sphere\"\n"),
            "t.pbrt:6:16: error: mix refers to named material \"nope\", which is not defined");
  EXPECT_EQ(error_of(defs + "Material \"mix\" \"string namedmaterial1\" \"a\"\n"
                            "  \"string namedmaterial2\" \"gone\"\n"),
            "t.pbrt:7:3: error: mix refers to named material \"gone\", which is not defined");
  EXPECT_EQ(error_of(defs + "  Material \"mix\" \"string namedmaterial1\" \"u\" "
                            "\"string namedmaterial2\" \"t\"\n"),
            "t.pbrt:6:3: error: weighted mix of \"translucent\" and \"uber\" has up to 9 lobes; at "
            "most 8 are supported (use --mix stochastic)");
  EXPECT_EQ(error_of(defs + "Material \"mix\" \"string namedmaterial1\" \"a\" "
                            "\"string namedmaterial2\" \"i\"\n"),
            "t.pbrt:6:1: error: a weighted (pbrt-v3) mix cannot contain an interface (material "
            "\"i\")");
  EXPECT_EQ(error_of(defs + "MakeNamedMaterial \"m\" \"string type\" \"mix\" \"string materials\" "
                            "[\"a\" \"u\"]\nMaterial \"mix\" \"string namedmaterial1\" \"m\" "
                            "\"string namedmaterial2\" \"a\"\n"),
            "t.pbrt:7:1: error: a weighted (pbrt-v3) mix cannot contain another mix (material "
            "\"m\"); render it with --mix stochastic");
  EXPECT_EQ(error_of("WorldBegin\nMakeNamedMaterial \"m\" \"string type\" \"mix\" "
                     "\"string materials\" [\"m\" \"m\"]\n"),
            "t.pbrt:2:1: error: material \"m\" contains itself (mix cycle)");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"mix\" \"string materials\" [\"a\"]\n"),
            "t.pbrt:2:16: error: mix needs exactly two names in \"string materials\", got 1");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"mix\" \"float amount\" 0.5\n"),
            "t.pbrt:2:1: error: mix needs \"string materials\" [ \"a\" \"b\" ] (pbrt-v4) or "
            "\"string namedmaterial1\" and \"string namedmaterial2\" (pbrt-v3)");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"mix\" \"string namedmaterial1\" \"a\"\n"),
            "t.pbrt:2:1: error: a pbrt-v3 mix needs both \"string namedmaterial1\" and "
            "\"string namedmaterial2\"");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"mix\" \"string materials\" [\"a\" \"b\"] "
                     "\"rgb amount\" [1 1 1]\n"),
            "t.pbrt:2:45: error: parameter \"amount\" has type rgb; expected float or texture");
  // Mixes nested 17 deep.
  std::string deep = "WorldBegin\nMakeNamedMaterial \"m0\" \"string type\" \"diffuse\"\n";
  for (int i = 1; i <= 17; ++i)
    deep += "MakeNamedMaterial \"m" + std::to_string(i) +
            "\" \"string type\" \"mix\" \"string materials\" [\"m" + std::to_string(i - 1) +
            "\" \"m0\"]\n";
  EXPECT_EQ(error_of(deep), "t.pbrt:19:1: error: mix materials nested more than 16 deep");

  EXPECT_EQ(error_of("WorldBegin\nMaterial \"conductor\" \"texture eta\" \"rust\"\n"),
            "t.pbrt:2:22: error: parameter \"eta\": spectrum texture \"rust\" is not defined");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"dielectric\" \"texture roughness\" \"r\"\n"),
            "t.pbrt:2:23: error: parameter \"uroughness\": float texture \"r\" is not defined");
  // docs/bump-spec.md 1: a missing normal map file, an undefined bump texture, a mix with a
  // displacement.
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"diffuse\" \"string normalmap\" \"n.png\"\n"),
            "t.pbrt:2:20: error: image file \"n.png\": No such file or directory");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"plastic\" \"texture bumpmap\" \"b\"\n"
                     "Shape \"sphere\"\n"),
            "t.pbrt:2:20: error: parameter \"displacement\": float texture \"b\" is not defined");
  EXPECT_EQ(error_of("WorldBegin\nMakeNamedMaterial \"x\" \"string type\" \"mix\" "
                     "\"string materials\" [\"a\" \"b\"] \"float displacement\" 0.1\n"),
            "t.pbrt:2:72: error: a 'mix' material takes no parameter \"displacement\"");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"conductor\" \"rgb reflectance\" [0.5 0.5 0.5]\n"
                     "  \"spectrum eta\" \"metal-Au-eta\"\n"),
            "t.pbrt:2:22: error: give either \"reflectance\" or \"eta\" and \"k\", not both "
            "(pbrt-v4 conductor)");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"metal\" \"string distribution\" \"blinn\"\n"),
            "t.pbrt:2:18: error: distribution \"blinn\" is not supported (\"trowbridgereitz\", "
            "the default, or \"beckmann\")");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"plastic\" \"float roughness\" -0.1\n"),
            "t.pbrt:2:20: error: parameter \"roughness\" must not be negative");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"dielectric\" \"rgb eta\" [1.5 1.5 1.5]\n"),
            "t.pbrt:2:23: error: parameter \"eta\" is an index of refraction: give a float or a "
            "spectrum, not an rgb value");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"dielectric\" \"float eta\" 0\n"),
            "t.pbrt:2:23: error: parameter \"eta\" must be positive");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"coateddiffuse\" \"integer nsamples\" 0\n"),
            "t.pbrt:2:26: error: nsamples must be at least 1");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"coateddiffuse\" \"float g\" 2\n"),
            "t.pbrt:2:26: error: parameter \"g\" must be in [-1, 1]");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"matte\" \"rgb Kd\" [-1 0 0]\n"),
            "t.pbrt:2:18: error: parameter \"Kd\" has a negative component");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"coateddiffuse\" \"rgb albedo\" [2 0 0]\n"),
            "t.pbrt:2:26: error: parameter \"albedo\" is a reflectance and has a component above 1");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"conductor\" \"spectrum eta\" \"metal-Pt-eta\"\n")
                .rfind("t.pbrt:2:22: error: unknown named spectrum \"metal-Pt-eta\" for parameter "
                       "\"eta\" (basalt knows metal-Ag-eta, ",
                       0),
            0u);
  EXPECT_EQ(error_of("WorldBegin\nLightSource \"point\" \"blackbody I\" [6500 1]\n"),
            "t.pbrt:2:21: error: blackbody parameter \"I\" takes one value, the temperature in "
            "Kelvin (pbrt-v4)");
  EXPECT_EQ(error_of("WorldBegin\nLightSource \"point\" \"blackbody I\" -5\n"),
            "t.pbrt:2:21: error: blackbody parameter \"I\" needs a positive temperature");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"measured\"\n"),
            "t.pbrt:2:1: error: measured needs a \"string filename\" parameter (a MERL .binary "
            "file)");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"measured\" \"string filename\" \"paint.bsdf\"\n"),
            "t.pbrt:2:21: error: RGL .bsdf measured BRDFs (pbrt-v4's format) are not supported; "
            "basalt reads MERL .binary tables (pbrt-v2's measured material)");
}

TEST(Spectra, Conversions) {
  // A constant spectrum maps to itself (reflectance rule), in any parameter.
  basalt::Spectrum c;
  c.lambda = {400.0, 700.0};
  c.value = {0.3, 0.3};
  glm::dvec3 rgb = basalt::spectrum_to_rgb_reflectance(c);
  EXPECT_NEAR(rgb.x, 0.3, 1e-12);
  EXPECT_NEAR(rgb.y, 0.3, 1e-12);
  EXPECT_NEAR(rgb.z, 0.3, 1e-12);
  EXPECT_EQ(slot(material_of("Material \"coateddiffuse\" \"spectrum albedo\" [300 0.7 900 0.7]"),
                 SLOT_CD_ALBEDO),
            glm::vec3(0.7f));
  // Copper: low eta in red, rising to blue; high k, falling to blue (docs/materials.md table).
  glm::vec3 eta = named("metal-Cu-eta"), k = named("metal-Cu-k");
  EXPECT_NEAR(eta.x, 0.42f, 0.02f);
  EXPECT_NEAR(eta.y, 0.95f, 0.02f);
  EXPECT_NEAR(eta.z, 1.16f, 0.02f);
  EXPECT_NEAR(k.x, 3.06f, 0.02f);
  EXPECT_NEAR(k.y, 2.61f, 0.02f);
  EXPECT_NEAR(k.z, 2.40f, 0.02f);
  EXPECT_LT(eta.x, eta.y);
  EXPECT_GT(k.x, k.z);
  // Blackbody 6500 K as light: about white, luminance 1 (times scale).
  glm::dvec3 bb = basalt::spectrum_to_rgb_illuminant(basalt::Spectrum::blackbody(6500.0));
  double Y = 0.2126729 * bb.x + 0.7151522 * bb.y + 0.0721750 * bb.z;  // sRGB luminance
  EXPECT_NEAR(Y, 1.0, 1e-3);
  EXPECT_NEAR(bb.x, 1.0, 0.07);
  EXPECT_NEAR(bb.y, 1.0, 0.07);
  EXPECT_NEAR(bb.z, 1.0, 0.07);
  // Lower temperatures are redder.
  glm::dvec3 warm = basalt::spectrum_to_rgb_illuminant(basalt::Spectrum::blackbody(2700.0));
  EXPECT_GT(warm.x, warm.y);
  EXPECT_GT(warm.y, warm.z);
  // The fitted CIE Y integrates to pbrt's CIE_Y_integral (106.857) within the fit's accuracy.
  double y = 0.0;
  for (double l = 360.0; l <= 830.0; l += 1.0) y += basalt::cie_xyz_fit(l).y;
  EXPECT_NEAR(y, 106.857, 0.5);
}

TEST(Spectra, LightsAcceptSpectra) {
  Scene s = parse(
      "WorldBegin\nLightSource \"point\" \"blackbody I\" 6500 \"float scale\" 3\n"
      "LightSource \"distant\" \"spectrum L\" [400 1 700 1]\n"
      "AreaLightSource \"diffuse\" \"blackbody L\" [ 2700 ]\nShape \"sphere\"\n");
  glm::vec3 bb = glm::vec3(basalt::spectrum_to_rgb_illuminant(basalt::Spectrum::blackbody(6500.0)));
  expect_vec_near(s.lights[0].value, 3.0f * bb);
  // Equal-energy white, normalised to luminance 1.
  glm::vec3 e = s.lights[1].value;
  EXPECT_NEAR(0.2126729f * e.x + 0.7151522f * e.y + 0.0721750f * e.z, 1.0f, 1e-3f);
  EXPECT_GT(e.x, e.z);
  glm::vec3 a = s.shapes[0].area_light->L;
  EXPECT_GT(a.x, a.z);
  EXPECT_TRUE(s.warnings.empty());
}

TEST(Spectra, DielectricEtaFromSpectrumIsTheValueAt550) {
  float bk7 = float(basalt::named_spectrum("glass-BK7")->eval(550.0));
  EXPECT_NEAR(bk7, 1.5185f, 1e-4f);
  EXPECT_EQ(material_of("Material \"dielectric\" \"spectrum eta\" \"glass-BK7\"")
                .value[SLOT_DIELECTRIC_ETA]
                .x,
            bk7);
  EXPECT_EQ(material_of("Material \"thindielectric\" \"spectrum eta\" [500 1.4 600 1.6]")
                .value[SLOT_THIN_ETA]
                .x,
            1.5f);
  auto m = material_of("Material \"metal\" \"spectrum eta\" \"metal-Au-eta\" "
                       "\"spectrum k\" \"metal-Au-k\"");
  EXPECT_EQ(slot(m, SLOT_CONDUCTOR_ETA), named("metal-Au-eta"));
  EXPECT_EQ(slot(m, SLOT_CONDUCTOR_K), named("metal-Au-k"));
}

TEST(Merl, WriterReaderRoundTrip) {
  fs::path d = temp_dir("merl");
  basalt::AnalyticBrdf brdf;
  const glm::uvec3 dims(8, 6, 10);
  basalt::write_merl((d / "t.binary").string(), dims,
                     [&](const glm::dvec3& wi, const glm::dvec3& wo) { return brdf.eval(wi, wo); });
  EXPECT_EQ(fs::file_size(d / "t.binary"), 12u + 3u * 8u * 6u * 10u * 8u);
  basalt::MeasuredTable t = basalt::read_merl((d / "t.binary").string());
  EXPECT_EQ(t.dims, dims);
  ASSERT_EQ(t.rgb.size(), 3u * 8u * 6u * 10u);
  int missing = 0;
  for (unsigned ih = 0; ih < dims.x; ++ih)
    for (unsigned id = 0; id < dims.y; ++id)
      for (unsigned ip = 0; ip < dims.z; ++ip) {
        std::size_t i = ip + dims.z * (id + dims.y * ih);
        glm::dvec3 wi, wo;
        bool ok = basalt::merl_bin_directions(dims, ih, id, ip, &wi, &wo);
        glm::dvec3 f = ok ? brdf.eval(wi, wo) : glm::dvec3(0.0);  // missing -> 0
        missing += !ok;
        for (int c = 0; c < 3; ++c)
          EXPECT_NEAR(t.rgb[3 * i + c], f[c], 1e-6 * std::max(1.0, f[c])) << i << " " << c;
        if (ok) {  // the bin's directions are reflections about the half vector
          glm::dvec3 h = glm::normalize(wi + wo);
          EXPECT_NEAR(std::acos(std::min(1.0, h.z)),
                      M_PI / 2 * std::pow((ih + 0.5) / dims.x, 2.0), 1e-9);
          EXPECT_NEAR(std::acos(glm::dot(wi, h)), M_PI / 2 * (id + 0.5) / dims.y, 1e-9);
        }
      }
  EXPECT_GT(missing, 0);  // grazing bins are below the surface

  // Errors: missing file, short header, short body.
  EXPECT_THROW(basalt::read_merl((d / "nope.binary").string()), std::runtime_error);
  write_file(d / "short.binary", std::string("\x02\x00\x00\x00", 4));
  EXPECT_THROW(basalt::read_merl((d / "short.binary").string()), std::runtime_error);
  std::string body = std::string("\x02\x00\x00\x00\x02\x00\x00\x00\x02\x00\x00\x00", 12) +
                     std::string(8 * 3 * 8 - 8, '\0');
  write_file(d / "body.binary", body);
  try {
    basalt::read_merl((d / "body.binary").string());
    FAIL();
  } catch (const std::runtime_error& e) {
    EXPECT_EQ(std::string(e.what()), "file is short: 2 x 2 x 2 needs 204 bytes, found 196");
  }
}

TEST(Merl, MeasuredMaterialInAScene) {
  fs::path d = temp_dir("merl_scene");
  fs::create_directories(d / "data");
  basalt::AnalyticBrdf brdf;
  basalt::write_merl((d / "data" / "p.binary").string(), glm::uvec3(4, 3, 5),
                     [&](const glm::dvec3& wi, const glm::dvec3& wo) { return brdf.eval(wi, wo); });
  Scene s = load_scene_from_string(
      "WorldBegin\nMaterial \"measured\" \"string filename\" \"data/p.binary\"\nShape \"sphere\"\n"
      "Material \"diffuse\"\nShape \"sphere\"\n"
      "Material \"measured\" \"string filename\" \"data/../data/p.binary\"\nShape \"sphere\"\n",
      "t.pbrt", d.string());
  ASSERT_EQ(s.measured.size(), 1u);  // the same file once
  basalt::SceneTables t = basalt::build_tables(s);
  EXPECT_EQ(t.measured.size(), 3u * 4u * 3u * 5u);
  const auto& m0 = t.materials[std::size_t(s.shapes[0].material)];
  const auto& m2 = t.materials[std::size_t(s.shapes[2].material)];
  EXPECT_EQ(m0.type, MATERIAL_MEASURED);
  EXPECT_EQ(m0.aux0, 0u);
  EXPECT_EQ(m2.aux0, 0u);
  EXPECT_EQ(m0.value[SLOT_MEASURED_DIMS], glm::vec4(4, 3, 5, 0));
  EXPECT_TRUE(t.features & FEATURE_MAT_MEASURED);
  EXPECT_EQ(t.measured, s.measured[0].rgb);

  EXPECT_EQ(error_of("WorldBegin\nMaterial \"measured\" \"string filename\" \"none.binary\"\n",
                     d.string()),
            "t.pbrt:2:21: error: measured BRDF file \"" + (d / "none.binary").string() +
                "\": No such file or directory");
  write_file(d / "bad.binary", "12345");
  EXPECT_EQ(error_of("WorldBegin\nMaterial \"measured\" \"string filename\" \"bad.binary\"\n",
                     d.string()),
            "t.pbrt:2:21: error: measured BRDF file \"" + (d / "bad.binary").string() +
                "\": file too short for the 12-byte header (3 int32 dimensions)");
}

TEST(Materials, TheCommittedMerlTableReads) {
  basalt::MeasuredTable t = basalt::read_merl(
      (fs::path(BASALT_SOURCE_DIR) / "scenes" / "data" / "gold-paint.binary").string());
  EXPECT_EQ(t.dims, glm::uvec3(32, 16, 32));
  EXPECT_LE(fs::file_size(fs::path(BASALT_SOURCE_DIR) / "scenes" / "data" / "gold-paint.binary"),
            400000u);
}

// Issue 11, defects 4, 6 and 7: a film too large for the renderer's tables is refused at its
// resolution (never a wrapped size or a bare bad_alloc), and a light's "scale" may not be
// negative (as "I" and "L" may not).
TEST(ParserErrors, SizesAndSignsAreCheckedWhereWritten) {
  const std::string film = "Film \"rgb\" \"integer xresolution\" [ ";
  EXPECT_EQ(error_of(film + "1073741824 ] \"integer yresolution\" [ 1073741824 ]\n" + kSphere),
            "t.pbrt:1:12: error: xresolution 1073741824 exceeds basalt's limit of 2^20 pixels");
  EXPECT_EQ(error_of(film + "65536 ] \"integer yresolution\" [ 65536 ]\n" + kSphere),
            "t.pbrt:1:12: error: a 65536 x 65536 film needs 68719476736 bytes of accumulation "
            "table, more than the 4294967296 bytes the renderer takes");
  // lavapipe's 128 MiB: 8388608 pixels.
  try {
    load_scene_from_string(film + "4096 ] \"integer yresolution\" [ 2049 ]\n" + kSphere, "t.pbrt",
                           ".", basalt::MixMode::Auto, std::uint64_t(1) << 27);
    ADD_FAILURE() << "4096 x 2049 accepted under 128 MiB";
  } catch (const SceneError& e) {
    EXPECT_NE(std::string(e.what()).find("needs 134283264 bytes"), std::string::npos) << e.what();
  }
  EXPECT_NO_THROW(load_scene_from_string(film + "4096 ] \"integer yresolution\" [ 2048 ]\n" +
                                             kSphere,
                                         "t.pbrt", ".", basalt::MixMode::Auto,
                                         std::uint64_t(1) << 27));
  for (const char* light : {"LightSource \"point\" \"float scale\" -1",
                            "LightSource \"distant\" \"float scale\" [ -0.5 ]",
                            "LightSource \"infinite\" \"float scale\" -2",
                            "AreaLightSource \"diffuse\" \"float scale\" -1"}) {
    const std::string e = error_of("WorldBegin\n" + std::string(light) + "\nShape \"sphere\"\n");
    EXPECT_NE(e.find("t.pbrt:2:"), std::string::npos) << light << ": " << e;
    EXPECT_NE(e.find("light \"scale\" must be finite and not negative"), std::string::npos)
        << light << ": " << e;
  }
  EXPECT_EQ(error_of("WorldBegin\nLightSource \"point\" \"float scale\" 0\n"), "");
  // An integer beyond int is an error before any cast (the fuzzer's first find in CI).
  EXPECT_EQ(error_of("Option \"integer seed\" 55555555555555555555555555555\n" +
                     std::string(kSphere)),
            "t.pbrt:1:23: error: Option \"seed\" does not fit a 32-bit integer");
}

// Issue 11, defect 8: Include and plymesh take regular files only; a device or a FIFO is an
// error at once (reading /dev/zero grew without bound, a FIFO blocked for ever).
TEST(ParserErrors, SpecialFilesAreRefused) {
  EXPECT_EQ(error_of("WorldBegin\nInclude \"/dev/zero\"\n"),
            "t.pbrt:2:1: error: cannot read included file \"/dev/zero\": is a device, not a "
            "regular file");
  EXPECT_EQ(error_of("WorldBegin\nShape \"plymesh\" \"string filename\" \"/dev/zero\"\n"),
            "t.pbrt:2:1: error: PLY file \"/dev/zero\": cannot read PLY file: is a device, not a "
            "regular file");
  const fs::path d = temp_dir("fifo");
  ASSERT_EQ(::mkfifo((d / "f.pbrt").c_str(), 0600), 0);
  EXPECT_EQ(error_of("WorldBegin\nImport \"f.pbrt\"\n", d.string()),
            "t.pbrt:2:1: error: cannot read included file \"" + (d / "f.pbrt").string() +
                "\": is a FIFO, not a regular file");
}
