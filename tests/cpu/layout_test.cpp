// Asserts the size and offset of every shared host/device struct (std430 layout rules).
#include <gtest/gtest.h>

#include <cstddef>

#include "../../shaders/shared/layout.h"

using namespace basalt::gpu;

TEST(Layout, SizesAndOffsets) {
  EXPECT_EQ(sizeof(Globals), 416u);
  EXPECT_EQ(offsetof(Globals, light_opts), 400u);
  EXPECT_EQ(offsetof(Globals, sampler_opts), 368u);
  EXPECT_EQ(offsetof(Globals, sampler_params), 384u);
  EXPECT_EQ(offsetof(Globals, render_opts), 352u);
  EXPECT_EQ(offsetof(Globals, camera_from_world), 288u);
  EXPECT_EQ(offsetof(Globals, screen), 64u);
  EXPECT_EQ(offsetof(Globals, lens), 80u);
  EXPECT_EQ(offsetof(Globals, filter_radius), 96u);
  EXPECT_EQ(offsetof(Globals, scene_sphere), 112u);
  EXPECT_EQ(offsetof(Globals, image), 128u);
  EXPECT_EQ(offsetof(Globals, counts), 144u);
  EXPECT_EQ(offsetof(Globals, infinite_lights), 160u);
  EXPECT_EQ(offsetof(Globals, features), 176u);
  EXPECT_EQ(offsetof(Globals, min_pos_dx), 192u);
  EXPECT_EQ(offsetof(Globals, min_dir_dy), 240u);
  EXPECT_EQ(offsetof(Globals, texture_opts), 256u);
  EXPECT_EQ(offsetof(Globals, tex_tables), 272u);
  EXPECT_EQ(sizeof(BvhNode), 32u);
  EXPECT_EQ(offsetof(BvhNode, a), 12u);
  EXPECT_EQ(offsetof(BvhNode, hi), 16u);
  EXPECT_EQ(offsetof(BvhNode, b), 28u);
  EXPECT_EQ(sizeof(Triangle), 16u);
  EXPECT_EQ(offsetof(Triangle, mesh), 12u);
  EXPECT_EQ(sizeof(Vertex), 32u);
  EXPECT_EQ(offsetof(Vertex, n_v), 16u);
  EXPECT_EQ(sizeof(Mesh), 16u);
  EXPECT_EQ(offsetof(Mesh, flags), 12u);
  EXPECT_EQ(sizeof(Sphere), 80u);
  EXPECT_EQ(offsetof(Sphere, axis_z), 48u);
  EXPECT_EQ(offsetof(Sphere, light), 68u);
  EXPECT_EQ(sizeof(Material), 336u);
  EXPECT_EQ(offsetof(Material, value), 16u);
  EXPECT_EQ(offsetof(Material, texture), 272u);
  EXPECT_EQ(sizeof(Light), 208u);
  EXPECT_EQ(offsetof(Light, bound_c), 160u);
  EXPECT_EQ(offsetof(Light, bound_w), 176u);
  EXPECT_EQ(offsetof(Light, bound_e), 192u);
  EXPECT_EQ(offsetof(Light, data), 80u);
  EXPECT_EQ(offsetof(Light, light_from_world), 96u);
  EXPECT_EQ(offsetof(Light, pmf), 12u);
  EXPECT_EQ(offsetof(Light, pos), 32u);
  EXPECT_EQ(offsetof(Light, params), 64u);
  EXPECT_EQ(sizeof(PassConstants), 32u);
  EXPECT_EQ(sizeof(ProbeIn), 96u);
  EXPECT_EQ(offsetof(ProbeIn, extra3), 80u);
  EXPECT_EQ(sizeof(Texture), 192u);
  EXPECT_EQ(offsetof(Texture, ip), 16u);
  EXPECT_EQ(offsetof(Texture, param), 32u);
  EXPECT_EQ(offsetof(Texture, map), 96u);
  EXPECT_EQ(offsetof(Texture, xform), 128u);
  EXPECT_EQ(sizeof(MipLevel), 16u);
  EXPECT_EQ(sizeof(ProbeOut), 80u);
  EXPECT_EQ(offsetof(ProbeOut, u), 64u);
}

TEST(Layout, FeatureBitsAreDistinct) {
  const uint bits[] = {FEATURE_TRIANGLES,   FEATURE_SPHERES,        FEATURE_LIGHT_POINT,
                       FEATURE_LIGHT_SPOT,  FEATURE_LIGHT_DISTANT,  FEATURE_LIGHT_INFINITE,
                       FEATURE_LIGHT_AREA,  FEATURE_MAT_DIFFUSE,    FEATURE_FILTER_GAUSSIAN,
                       FEATURE_THIN_LENS,   FEATURE_SHADING_NORMALS,
                       FEATURE_MAT_OREN_NAYAR, FEATURE_MAT_CONDUCTOR, FEATURE_MAT_DIELECTRIC,
                       FEATURE_MAT_THIN_DIELECTRIC, FEATURE_MAT_DIFFUSE_TRANSMISSION,
                       FEATURE_MAT_COATED_DIFFUSE, FEATURE_MAT_COATED_CONDUCTOR,
                       FEATURE_MAT_PLASTIC, FEATURE_MAT_SUBSTRATE, FEATURE_MAT_TRANSLUCENT,
                       FEATURE_MAT_UBER, FEATURE_MAT_MEASURED, FEATURE_MAT_MIX,
                       FEATURE_MAT_MIX_WEIGHTED, FEATURE_MAT_INTERFACE, FEATURE_MAT_MIRROR,
                       FEATURE_MAT_METAL, FEATURE_TEXTURES, FEATURE_TEX_NOISE,
                       FEATURE_TEX_IMAGE, FEATURE_LIGHT_INFINITE_IMAGE};
  static_assert(sizeof(bits) / sizeof(bits[0]) == FEATURE_COUNT);
  uint all = 0;
  for (uint b : bits) {
    EXPECT_EQ(all & b, 0u);
    all |= b;
  }
}
