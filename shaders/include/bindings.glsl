// The pipeline interface shared by render.comp and tests/probe.comp: the scene tables of
// descriptor set 0 (layouts and binding indices from shared/layout.h) and the feature
// specialization constant.
#ifndef BASALT_BINDINGS_GLSL
#define BASALT_BINDINGS_GLSL

#include "shared/layout.h"

// Feature bits of the scene (FEATURE_*): the host specialises the render pipeline so that
// code for absent features is constant-folded away. Every optional part of the shaders is
// gated by has_feature(FEATURE_X); all bits set (the default, used by the probe) must
// render every scene correctly.
layout(constant_id = 0) const uint FEATURES = 0xffffffffu;
// The second feature word (FEATURE2_*: texture families), specialization constant 1.
layout(constant_id = 1) const uint FEATURES2 = 0xffffffffu;
// Whether the scene's feature set includes one of `bits` (FEATURE_*; has_feature2: FEATURE2_*).
// Macros, not functions: at each use the test is then a constant expression of the
// specialization constant, which the host's SPIR-V specialisation (host/vk/specialise.h) folds
// and removes the dead branch of; behind a function parameter it stayed, with all it guards.
// A build variant may rule bits out for good (BASALT_FEATURES_KEEP and BASALT_FEATURES2_KEEP,
// the bits it can render; BASALT_PLAIN: the plain variants of layout.h): a test of such bits
// is then the constant false already in glslang's output, which the build's own dead-code
// passes remove (cmake/Shaders.cmake, PRUNE), so that the scene-time specialisation starts
// from a smaller module. The host picks such a variant only for scenes without those bits.
#ifdef BASALT_PLAIN
#define BASALT_FEATURES_KEEP FEATURES_PLAIN_KEEP
#define BASALT_FEATURES2_KEEP FEATURES2_PLAIN_KEEP
#endif
// no_feature: none of `bits`, written out rather than as !has_feature(bits), which glslang
// 12 turns into an invalid module when it is a constant-false && (a specialization-constant
// LogicalNot of a phi).
// A global constant needs the third form, feature_const: glslang cannot initialise one with
// the short-circuit && or || of the first two in a build variant (again an invalid module).
// It rules the variant's bits out too, in a specialization-constant operation that the
// scene-time specialisation folds.
#ifdef BASALT_FEATURES_KEEP
#define feature_const(bits) ((FEATURES & ((bits) & BASALT_FEATURES_KEEP)) != 0u)
#define has_feature(bits) (((bits) & BASALT_FEATURES_KEEP) != 0u && (FEATURES & (bits)) != 0u)
#define no_feature(bits) (((bits) & BASALT_FEATURES_KEEP) == 0u || (FEATURES & (bits)) == 0u)
#else
#define feature_const(bits) ((FEATURES & (bits)) != 0u)
#define has_feature(bits) ((FEATURES & (bits)) != 0u)
#define no_feature(bits) ((FEATURES & (bits)) == 0u)
#endif
#ifdef BASALT_FEATURES2_KEEP
#define feature2_const(bits) ((FEATURES2 & ((bits) & BASALT_FEATURES2_KEEP)) != 0u)
#define has_feature2(bits) (((bits) & BASALT_FEATURES2_KEEP) != 0u && (FEATURES2 & (bits)) != 0u)
#define no_feature2(bits) (((bits) & BASALT_FEATURES2_KEEP) == 0u || (FEATURES2 & (bits)) == 0u)
#else
#define feature2_const(bits) ((FEATURES2 & (bits)) != 0u)
#define has_feature2(bits) ((FEATURES2 & (bits)) != 0u)
#define no_feature2(bits) ((FEATURES2 & (bits)) == 0u)
#endif
// Specialization constant 2: 1 when the leaf_prims table is bound (BINDING_LEAF_PRIMS), 0 when
// the scene's is too large for one binding and leaves read prim_refs, triangles and vertices.
// A table format, not a feature: the host sets it for every pipeline, the probe's included.
layout(constant_id = 2) const uint LEAF_PRIMS = 1u;
// Specialization constant 3: 1 when the hot tables are read through their uniform texel
// views (BINDING_*_TEXELS of layout.h), 0 when one of them is beyond the device's
// maxTexelBufferElements and all are read as storage buffers. A table format, like LEAF_PRIMS.
layout(constant_id = 3) const uint TEXEL_TABLES = 1u;

layout(std430, set = 0, binding = BINDING_GLOBALS) restrict readonly buffer GlobalsBuffer {
  Globals globals;
};
// A read-only scene table: binding BINDING_<b>, block <Block>, array <name> of <T>.
#define BASALT_TABLE(b, Block, T, name) \
  layout(std430, set = 0, binding = BINDING_##b) restrict readonly buffer Block { T name[]; }
// Wide BVH nodes (BvhWideNode, docs/path-spec.md 3.1), read as four uvec4 each: lavapipe turns
// every storage-buffer load into a loop over its lanes, so wide loads beat scalar ones.
BASALT_TABLE(BVH_NODES, BvhNodeBuffer, uvec4, bvh_words);
// The texel views of the geometry tables (read when TEXEL_TABLES is 1).
layout(set = 0, binding = BINDING_BVH_TEXELS) uniform usamplerBuffer bvh_texels;
layout(set = 0, binding = BINDING_LEAF_TEXELS) uniform usamplerBuffer leaf_texels;
layout(set = 0, binding = BINDING_TRIANGLE_TEXELS) uniform usamplerBuffer triangle_texels;
layout(set = 0, binding = BINDING_VERTEX_TEXELS) uniform usamplerBuffer vertex_texels;
layout(set = 0, binding = BINDING_MESH_TEXELS) uniform usamplerBuffer mesh_texels;
layout(set = 0, binding = BINDING_TEXELS0_TEXELS) uniform usamplerBuffer texels0_texels;
layout(set = 0, binding = BINDING_TEXELS1_TEXELS) uniform usamplerBuffer texels1_texels;
layout(set = 0, binding = BINDING_TEXELS2_TEXELS) uniform usamplerBuffer texels2_texels;
layout(set = 0, binding = BINDING_TEXELS3_TEXELS) uniform usamplerBuffer texels3_texels;
layout(set = 0, binding = BINDING_TEX_DATA_TEXELS) uniform usamplerBuffer tex_data_texels;
layout(set = 0, binding = BINDING_SAMPLER_TEXELS) uniform usamplerBuffer sampler_texels;
layout(set = 0, binding = BINDING_MATERIAL_TEXELS) uniform usamplerBuffer material_texels;
layout(set = 0, binding = BINDING_LIGHT_TEXELS) uniform usamplerBuffer light_texels;
layout(set = 0, binding = BINDING_SPHERE_TEXELS) uniform usamplerBuffer sphere_texels;
layout(set = 0, binding = BINDING_MIP_LEVEL_TEXELS) uniform usamplerBuffer mip_level_texels;
layout(set = 0, binding = BINDING_TEXTURE_TEXELS) uniform usamplerBuffer texture_texels;
BASALT_TABLE(PRIM_REFS, PrimRefBuffer, uint, prim_refs);
BASALT_TABLE(LEAF_PRIMS, LeafPrimBuffer, vec4, leaf_prims);
BASALT_TABLE(TRIANGLES, TriangleBuffer, Triangle, triangles);
BASALT_TABLE(VERTICES, VertexBuffer, Vertex, vertices);
BASALT_TABLE(MESHES, MeshBuffer, Mesh, meshes);
BASALT_TABLE(SPHERES, SphereBuffer, Sphere, spheres);
BASALT_TABLE(MATERIALS, MaterialBuffer, Material, materials);
BASALT_TABLE(LIGHTS, LightBuffer, Light, lights);
BASALT_TABLE(LIGHT_CDF, LightCdfBuffer, float, light_cdf);
BASALT_TABLE(FILTER_CDF, FilterCdfBuffer, float, filter_cdf);
layout(std430, set = 0, binding = BINDING_ACCUM) restrict buffer AccumBuffer {
  vec4 accum[];  // per pixel: running sum of (L, weight)
};
layout(std430, set = 0, binding = BINDING_COUNTERS) restrict buffer CounterBuffer {
  uint counters[];  // [0]: rays traced in this pass (one atomicAdd per invocation)
};

// MERL half-angle tables, rgb interleaved (MATERIAL_MEASURED aux0).
BASALT_TABLE(MEASURED, MeasuredBuffer, float, measured);

// Textures (docs/textures-spec.md): programs, image levels, texels, shared tables.
BASALT_TABLE(TEXTURES, TextureBuffer, Texture, textures);
BASALT_TABLE(MIP_LEVELS, MipLevelBuffer, MipLevel, mip_levels);
BASALT_TABLE(TEXELS, TexelBuffer, float, texels);
BASALT_TABLE(TEXELS1, TexelBuffer1, float, texels1);
BASALT_TABLE(TEXELS2, TexelBuffer2, float, texels2);
BASALT_TABLE(TEXELS3, TexelBuffer3, float, texels3);
BASALT_TABLE(TEX_DATA, TexDataBuffer, float, tex_data);
// The first SAMPLER_PRIME_COUNT primes (docs/sampler-spec.md 3).
BASALT_TABLE(SAMPLER_DATA, SamplerDataBuffer, uint, sampler_data);

// The geometry tables' entries, through the texel views or the storage tables (TEXEL_TABLES).
// uvec4 i of the wide BVH (node n: 4n .. 4n + 3).
uvec4 bvh_word(uint i) { return TEXEL_TABLES != 0u ? texelFetch(bvh_texels, int(i)) : bvh_words[i]; }
// Number of uvec4 in the wide BVH table (4 per node; 1 for a scene without primitives).
uint bvh_word_count() {
  return TEXEL_TABLES != 0u ? uint(textureSize(bvh_texels)) : uint(bvh_words.length());
}
// vec4 i of the leaf_prims table.
vec4 leaf_prim(uint i) {
  return TEXEL_TABLES != 0u ? uintBitsToFloat(texelFetch(leaf_texels, int(i))) : leaf_prims[i];
}
// Triangle i.
Triangle triangle_at(uint i) {
  if (TEXEL_TABLES == 0u) return triangles[i];
  uvec4 w = texelFetch(triangle_texels, int(i));
  return Triangle(w.x, w.y, w.z, w.w);
}
// Position and u of vertex i.
vec4 vertex_p_u(uint i) {
  return TEXEL_TABLES != 0u ? uintBitsToFloat(texelFetch(vertex_texels, int(2u * i)))
                            : vertices[i].p_u;
}
// Normal and v of vertex i.
vec4 vertex_n_v(uint i) {
  return TEXEL_TABLES != 0u ? uintBitsToFloat(texelFetch(vertex_texels, int(2u * i + 1u)))
                            : vertices[i].n_v;
}
// Mesh i.
Mesh mesh_at(uint i) {
  if (TEXEL_TABLES == 0u) return meshes[i];
  uvec4 w = texelFetch(mesh_texels, int(i));
  return Mesh(w.x, w.y, w.z, w.w);
}

// The shading tables' entries (TEXEL_TABLES as above); a struct read whole is built from its
// texels, and the fetches of the fields a caller does not use are removed as dead code.
// uvec4 k of table view v as floats.
#define TEXEL_F(v, k) uintBitsToFloat(texelFetch(v, int(k)))
// Material m's type, flags, aux0 and aux1.
uvec4 material_head(uint m) {
  if (TEXEL_TABLES == 0u)
    return uvec4(materials[m].type, materials[m].flags, materials[m].aux0, materials[m].aux1);
  return texelFetch(material_texels, int(21u * m));
}
// Constant value of slot s of material m.
vec4 material_value(uint m, uint s) {
  return TEXEL_TABLES != 0u ? TEXEL_F(material_texels, 21u * m + 1u + s) : materials[m].value[s];
}
// Texture of slot s of material m (INVALID_INDEX: the constant).
uint material_texture(uint m, uint s) {
  if (TEXEL_TABLES == 0u) return materials[m].texture[s / 4u][s % 4u];
  return texelFetch(material_texels, int(21u * m + 17u + s / 4u))[s % 4u];
}
// Textures of slots 4q .. 4q + 3 of material m.
uvec4 material_textures4(uint m, uint q) {
  if (TEXEL_TABLES == 0u) return materials[m].texture[q];
  return texelFetch(material_texels, int(21u * m + 17u + q));
}
// Light i.
Light light_at(uint i) {
  if (TEXEL_TABLES == 0u) return lights[i];
  uint k = 13u * i;
  uvec4 h = texelFetch(light_texels, int(k));
  return Light(h.x, h.y, h.z, uintBitsToFloat(h.w), TEXEL_F(light_texels, k + 1u),
               TEXEL_F(light_texels, k + 2u), TEXEL_F(light_texels, k + 3u),
               TEXEL_F(light_texels, k + 4u), texelFetch(light_texels, int(k + 5u)),
               mat4(TEXEL_F(light_texels, k + 6u), TEXEL_F(light_texels, k + 7u),
                    TEXEL_F(light_texels, k + 8u), TEXEL_F(light_texels, k + 9u)),
               TEXEL_F(light_texels, k + 10u), TEXEL_F(light_texels, k + 11u),
               TEXEL_F(light_texels, k + 12u));
}
// Sphere i.
Sphere sphere_at(uint i) {
  if (TEXEL_TABLES == 0u) return spheres[i];
  uint k = 5u * i;
  uvec4 t = texelFetch(sphere_texels, int(k + 4u));
  return Sphere(TEXEL_F(sphere_texels, k), TEXEL_F(sphere_texels, k + 1u),
                TEXEL_F(sphere_texels, k + 2u), TEXEL_F(sphere_texels, k + 3u), t.x, t.y, t.z,
                t.w);
}
// MipLevel i.
MipLevel mip_level_at(uint i) {
  if (TEXEL_TABLES == 0u) return mip_levels[i];
  uvec4 w = texelFetch(mip_level_texels, int(i));
  return MipLevel(w.x, w.y, w.z, w.w);
}
// Texture instruction i.
Texture texture_at(uint i) {
  if (TEXEL_TABLES == 0u) return textures[i];
  uint k = 12u * i;
  uvec4 h = texelFetch(texture_texels, int(k));
  return Texture(h.x, h.y, h.z, h.w, texelFetch(texture_texels, int(k + 1u)),
                 vec4[4](TEXEL_F(texture_texels, k + 2u), TEXEL_F(texture_texels, k + 3u),
                         TEXEL_F(texture_texels, k + 4u), TEXEL_F(texture_texels, k + 5u)),
                 vec4[2](TEXEL_F(texture_texels, k + 6u), TEXEL_F(texture_texels, k + 7u)),
                 mat4(TEXEL_F(texture_texels, k + 8u), TEXEL_F(texture_texels, k + 9u),
                      TEXEL_F(texture_texels, k + 10u), TEXEL_F(texture_texels, k + 11u)));
}

// Float g of the texel table, which spans up to TEXEL_CHUNK_COUNT bindings of 2^25 floats
// (layout.h): every texel read goes through here.
float texel_at(uint g) {
  uint c = g >> TEXEL_CHUNK_SHIFT, i = g & ((1u << TEXEL_CHUNK_SHIFT) - 1u);
  if (TEXEL_TABLES != 0u) {
    if (c == 0u) return uintBitsToFloat(texelFetch(texels0_texels, int(i)).x);
    if (c == 1u) return uintBitsToFloat(texelFetch(texels1_texels, int(i)).x);
    if (c == 2u) return uintBitsToFloat(texelFetch(texels2_texels, int(i)).x);
    return uintBitsToFloat(texelFetch(texels3_texels, int(i)).x);
  }
  if (c == 0u) return texels[i];
  if (c == 1u) return texels1[i];
  if (c == 2u) return texels2[i];
  return texels3[i];
}

// Float i of the shared texture tables (BINDING_TEX_DATA).
float tex_data_at(uint i) {
  return TEXEL_TABLES != 0u ? uintBitsToFloat(texelFetch(tex_data_texels, int(i)).x) : tex_data[i];
}

// Word i of the sampler tables (BINDING_SAMPLER_DATA).
uint sampler_data_at(uint i) {
  return TEXEL_TABLES != 0u ? texelFetch(sampler_texels, int(i)).x : sampler_data[i];
}

#endif
