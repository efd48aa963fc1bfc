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
#define BINDING_MEASURED 13  // float measured[]: tabulated BRDFs (MERL half-angle, rgb interleaved)
#define BINDING_TEXTURES 14  // Texture textures[]: texture programs (docs/textures-spec.md 2)
#define BINDING_MIP_LEVELS 15  // MipLevel mip_levels[]: one entry per level of every image
#define BINDING_TEXELS 16    // float texels[]: image levels, channel-interleaved, linear; the
                             //   first TEXEL_CHUNK floats (chunk 0, see TEXEL_CHUNK_SHIFT)
#define BINDING_TEX_DATA 17  // float tex_data[]: shared tables (docs/textures-spec.md 5):
                             //   noise permutation, EWA weights, Shirley gradients,
                             //   environment-map sampling distributions
#define BINDING_TEXELS1 18   // texels chunks 1, 2 and 3 (floats TEXEL_CHUNK k .. ); each binding
#define BINDING_TEXELS2 19   //   stays within every device's maxStorageBufferRange (at least
#define BINDING_TEXELS3 20   //   2^27 bytes in Vulkan), so image data may total 512 MiB
#define BINDING_SAMPLER_DATA 21  // uint sampler_data[]: the first SAMPLER_PRIME_COUNT primes,
                                 //   then the sobol or pmj02bn tables (docs/sampler-spec.md 3)
#define BINDING_LEAF_PRIMS 22  // vec4 leaf_prims[]: per prim_refs entry k, three vec4: the
                               //   triangle's positions p0, p1, p2 (w of p0: the ref's bits;
                               //   a sphere's entry holds only that), so a leaf's triangles are
                               //   read without the triangle and vertex tables; 16 zero bytes
                               //   when absent (specialization constant LEAF_PRIMS = 0)
#define BINDING_COUNT 23  // the storage tables above, one buffer each
// Uniform texel views (R32G32B32A32_UINT, one uvec4 a texel) of the geometry tables above, bound
// beside them: lavapipe fetches a texel with one branch-free gather where it turns a
// storage-buffer load into a loop over its lanes with a branch each (docs/performance.md).
// Read through them when specialization constant 3, TEXEL_TABLES, is 1 (every view within
// the device's maxTexelBufferElements), else through the storage tables.
#define BINDING_BVH_TEXELS 23       // view of BINDING_BVH_NODES
#define BINDING_LEAF_TEXELS 24      // view of BINDING_LEAF_PRIMS
#define BINDING_TRIANGLE_TEXELS 25  // view of BINDING_TRIANGLES
#define BINDING_VERTEX_TEXELS 26    // view of BINDING_VERTICES
#define BINDING_MESH_TEXELS 27      // view of BINDING_MESHES
// R32_UINT views (one uint or float bits a texel) of the texture and sampler tables.
#define BINDING_TEXELS0_TEXELS 28   // view of BINDING_TEXELS (image texels, chunk 0)
#define BINDING_TEXELS1_TEXELS 29   // view of BINDING_TEXELS1
#define BINDING_TEXELS2_TEXELS 30   // view of BINDING_TEXELS2
#define BINDING_TEXELS3_TEXELS 31   // view of BINDING_TEXELS3
#define BINDING_TEX_DATA_TEXELS 32  // view of BINDING_TEX_DATA
#define BINDING_SAMPLER_TEXELS 33   // view of BINDING_SAMPLER_DATA
// R32G32B32A32_UINT views of the shading tables (their structs are whole uvec4s).
#define BINDING_MATERIAL_TEXELS 34  // view of BINDING_MATERIALS (21 texels a Material)
#define BINDING_LIGHT_TEXELS 35     // view of BINDING_LIGHTS (13 texels a Light)
#define BINDING_SPHERE_TEXELS 36    // view of BINDING_SPHERES (5 texels a Sphere)
#define BINDING_MIP_LEVEL_TEXELS 37 // view of BINDING_MIP_LEVELS (1 texel a MipLevel)
#define BINDING_TEXTURE_TEXELS 38   // view of BINDING_TEXTURES (12 texels a Texture)
#define TEXEL_VIEW_COUNT 16  // within Vulkan's minimum maxPerStageDescriptorSampledImages (16)
// Texel index g (a float index into the whole texel table) lives in chunk g >> TEXEL_CHUNK_SHIFT
// at index g & (TEXEL_CHUNK - 1) of that chunk's binding.
#define TEXEL_CHUNK_SHIFT 25u
#define TEXEL_CHUNK_COUNT 4u

// Probe shaders (tests) add their input and output tables to the same set, well above the
// scene bindings so that later issues can append scene tables without moving them.
#define BINDING_WF_PATH_TEXELS 47  // the wavefront's paths (BINDING_PROBE_IN) as a texel view
#define BINDING_PROBE_IN 48
#define BINDING_PROBE_OUT 49

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
// Material kinds (issue 3): one bit per MATERIAL_* tag other than diffuse.
BASALT_CONST uint FEATURE_MAT_OREN_NAYAR = 1u << 11;
BASALT_CONST uint FEATURE_MAT_CONDUCTOR = 1u << 12;
BASALT_CONST uint FEATURE_MAT_DIELECTRIC = 1u << 13;
BASALT_CONST uint FEATURE_MAT_THIN_DIELECTRIC = 1u << 14;
BASALT_CONST uint FEATURE_MAT_DIFFUSE_TRANSMISSION = 1u << 15;
BASALT_CONST uint FEATURE_MAT_COATED_DIFFUSE = 1u << 16;
BASALT_CONST uint FEATURE_MAT_COATED_CONDUCTOR = 1u << 17;
BASALT_CONST uint FEATURE_MAT_PLASTIC = 1u << 18;
BASALT_CONST uint FEATURE_MAT_SUBSTRATE = 1u << 19;
BASALT_CONST uint FEATURE_MAT_TRANSLUCENT = 1u << 20;
BASALT_CONST uint FEATURE_MAT_UBER = 1u << 21;
BASALT_CONST uint FEATURE_MAT_MEASURED = 1u << 22;
BASALT_CONST uint FEATURE_MAT_MIX = 1u << 23;           // pbrt-v4 stochastic mix
BASALT_CONST uint FEATURE_MAT_MIX_WEIGHTED = 1u << 24;  // pbrt-v2/v3 weighted mix
BASALT_CONST uint FEATURE_MAT_INTERFACE = 1u << 25;
BASALT_CONST uint FEATURE_MAT_MIRROR = 1u << 26;
BASALT_CONST uint FEATURE_MAT_METAL = 1u << 27;
// Textures (issue 8): one bit per texture family a material of the scene reaches, so that a
// scene without textures, or with checkerboards only, does not pay for the rest.
BASALT_CONST uint FEATURE_TEXTURES = 1u << 28;        // any texture program at all (uv, ctx)
BASALT_CONST uint FEATURE_TEX_NOISE = 1u << 29;       // fbm, wrinkled, windy, marble, Shirley
BASALT_CONST uint FEATURE_TEX_IMAGE = 1u << 30;       // imagemap (any filter)
BASALT_CONST uint FEATURE_LIGHT_INFINITE_IMAGE = 1u << 31;  // image (environment) infinite light
BASALT_CONST uint FEATURE_COUNT = 32u;
// Second feature word (Globals.features.y, specialization constant 1): finer texture bits.
BASALT_CONST uint FEATURE2_TEX_EWA = 1u << 0;          // an image map filtered with EWA
BASALT_CONST uint FEATURE2_TEX_CHECKER_AA = 1u << 1;   // checkerboard (closed-form box filter)
BASALT_CONST uint FEATURE2_TEX_PROCEDURAL = 1u << 2;   // bilerp, dots, directionmix, mix, scale
BASALT_CONST uint FEATURE2_NOISE_SPLIT = 1u << 3;      // noise precision mode "split"
BASALT_CONST uint FEATURE2_TEX_SHIRLEY = 1u << 4;      // Shirley's solid textures (extensions)
BASALT_CONST uint FEATURE2_TEX_MAP_CURVED = 1u << 5;   // a spherical or cylindrical 2D mapping
BASALT_CONST uint FEATURE2_ENV_PORTAL = 1u << 6;       // an environment map seen through a portal
BASALT_CONST uint FEATURE2_BUMP = 1u << 7;             // a bump-mapped material (bump-spec 4)
BASALT_CONST uint FEATURE2_NORMALMAP = 1u << 8;        // a normal-mapped material (bump-spec 5)
BASALT_CONST uint FEATURE2_VTURB = 1u << 9;            // vector-turbulence normals (bump-spec 9)
// The scene's sampler (docs/sampler-spec.md), one bit per sampler but independent, set with
// Globals.sampler_opts (sampler_tables): lavapipe runs the code of both sides of a branch on a
// uniform, so the independent sampler compiles none of the others. Without its bit a sampler
// renders as independent.
BASALT_CONST uint FEATURE2_SAMPLER_STRATIFIED = 1u << 10;
BASALT_CONST uint FEATURE2_SAMPLER_HALTON = 1u << 11;
BASALT_CONST uint FEATURE2_SAMPLER_PADDED_SOBOL = 1u << 12;
BASALT_CONST uint FEATURE2_SAMPLER_ZSOBOL = 1u << 13;
BASALT_CONST uint FEATURE2_SAMPLER_SOBOL = 1u << 14;
BASALT_CONST uint FEATURE2_SAMPLER_PMJ02BN = 1u << 15;
BASALT_CONST uint FEATURE2_SAMPLERS = 0x3fu << 10;     // all six
BASALT_CONST uint FEATURE2_LIGHT_IMPORTANCE = 1u << 16;  // lights picked by importance (path-spec 6.1)
// The sampler's randomization is full Owen scrambling (RAND_OWEN): only such pipelines hold
// its loop of 31 hashes, which lavapipe enters even where no lane needs it (sampler.glsl).
BASALT_CONST uint FEATURE2_SAMPLER_OWEN = 1u << 17;
BASALT_CONST uint FEATURE2_COUNT = 18u;
// The bits the plain shader variants can render (BASALT_PLAIN in bindings.glsl): everything
// but textures, image lights and bump, normal and displacement-texture mapping. The noise
// precision bit stays: the host sets it without noise textures, and only noise code reads it.
BASALT_CONST uint FEATURES_PLAIN_KEEP =
    ~(FEATURE_TEXTURES | FEATURE_TEX_NOISE | FEATURE_TEX_IMAGE | FEATURE_LIGHT_INFINITE_IMAGE);
BASALT_CONST uint FEATURES2_PLAIN_KEEP = FEATURE2_NOISE_SPLIT | FEATURE2_SAMPLERS |
                                         FEATURE2_LIGHT_IMPORTANCE | FEATURE2_SAMPLER_OWEN;

// ---- primitive references ------------------------------------------------------------
// A BVH leaf covers prim_refs[a .. a+b). A ref is a triangle index, or a sphere index
// with PRIM_SPHERE_BIT set.
BASALT_CONST uint PRIM_SPHERE_BIT = 0x80000000u;
BASALT_CONST uint PRIM_INDEX_MASK = 0x7fffffffu;
BASALT_CONST uint INVALID_INDEX = 0xffffffffu;

// ---- material tags ---------------------------------------------------------------------
// One tag per material kind; docs/materials-spec.md section 3 says how each becomes lobes.
// Each slot holds one parameter: rgb in xyz (a float parameter in x) and may be a texture.
BASALT_CONST uint MATERIAL_NONE = 0u;           // no material: black, the path ends
BASALT_CONST uint MATERIAL_DIFFUSE = 1u;        // pbrt-v4 diffuse
BASALT_CONST uint MATERIAL_OREN_NAYAR = 2u;     // pbrt-v3 matte with sigma
BASALT_CONST uint MATERIAL_CONDUCTOR = 3u;      // pbrt-v4 conductor
BASALT_CONST uint MATERIAL_DIELECTRIC = 4u;     // pbrt-v4 dielectric, pbrt-v3 glass
BASALT_CONST uint MATERIAL_THIN_DIELECTRIC = 5u;
BASALT_CONST uint MATERIAL_DIFFUSE_TRANSMISSION = 6u;
BASALT_CONST uint MATERIAL_COATED_DIFFUSE = 7u;
BASALT_CONST uint MATERIAL_COATED_CONDUCTOR = 8u;
BASALT_CONST uint MATERIAL_PLASTIC = 9u;        // pbrt-v3 plastic
BASALT_CONST uint MATERIAL_SUBSTRATE = 10u;     // pbrt-v3 substrate
BASALT_CONST uint MATERIAL_TRANSLUCENT = 11u;   // pbrt-v3 translucent
BASALT_CONST uint MATERIAL_UBER = 12u;          // pbrt-v3 uber
BASALT_CONST uint MATERIAL_MEASURED = 13u;      // pbrt-v2 measured (MERL half-angle table)
BASALT_CONST uint MATERIAL_MIX = 14u;           // pbrt-v4 mix: stochastic choice
BASALT_CONST uint MATERIAL_MIX_WEIGHTED = 15u;  // pbrt-v2/v3 mix: weighted sum of lobes
BASALT_CONST uint MATERIAL_INTERFACE = 16u;     // pbrt-v4 interface: no surface, pass through
BASALT_CONST uint MATERIAL_MIRROR = 17u;        // pbrt-v3 mirror
BASALT_CONST uint MATERIAL_METAL = 18u;         // pbrt-v3 metal
BASALT_CONST uint MATERIAL_TYPE_COUNT = 19u;
BASALT_CONST uint MATERIAL_SLOTS = 16u;

// Material.flags
BASALT_CONST uint MATFLAG_REMAP_MASK = 3u;       // roughness -> alpha for every roughness slot:
BASALT_CONST uint MATFLAG_REMAP_NONE = 0u;       //   alpha = roughness
BASALT_CONST uint MATFLAG_REMAP_SQRT = 1u;       //   pbrt-v4: alpha = sqrt(roughness)
BASALT_CONST uint MATFLAG_REMAP_V3 = 2u;         //   pbrt-v3 RoughnessToAlpha polynomial
BASALT_CONST uint MATFLAG_BECKMANN = 1u << 2;    // microfacet lobes use Beckmann, not TR
BASALT_CONST uint MATFLAG_USE_REFLECTANCE = 1u << 3;  // conductors: Fresnel from reflectance
BASALT_CONST uint MATFLAG_BUMP = 1u << 4;       // displacement slot given (docs/bump-spec.md 2)
BASALT_CONST uint MATFLAG_NORMALMAP = 1u << 5;  // normal map in SLOT_NORMALMAP (bump-spec 2)
BASALT_CONST uint MATFLAG_LAYERED_PBRT_MIS = 1u << 7;  // coated: pbrt-v4's exit MIS weights in f
                                                     // (--layered-mis; materials-spec 2.3)
BASALT_CONST uint MATFLAG_VTURB = 1u << 6;      // Shirley's vector turbulence: value[SLOT_NORMALMAP]
                                                // .y = k1, .z = k2, .w = octaves (bump-spec 9)

// Slots (index into Material.value / texture). Float parameters use x.
BASALT_CONST uint SLOT_DIFFUSE_REFLECTANCE = 0u;
BASALT_CONST uint SLOT_ON_REFLECTANCE = 0u, SLOT_ON_SIGMA = 1u;  // sigma in degrees
BASALT_CONST uint SLOT_CONDUCTOR_ETA = 0u, SLOT_CONDUCTOR_K = 1u,
                  SLOT_CONDUCTOR_REFLECTANCE = 2u, SLOT_CONDUCTOR_UROUGH = 3u,
                  SLOT_CONDUCTOR_VROUGH = 4u;  // also pbrt-v3 metal
BASALT_CONST uint SLOT_MIRROR_KR = 0u;
BASALT_CONST uint SLOT_DIELECTRIC_ETA = 0u, SLOT_DIELECTRIC_UROUGH = 1u,
                  SLOT_DIELECTRIC_VROUGH = 2u, SLOT_DIELECTRIC_KR = 3u, SLOT_DIELECTRIC_KT = 4u;
BASALT_CONST uint SLOT_THIN_ETA = 0u;
BASALT_CONST uint SLOT_DT_REFLECTANCE = 0u, SLOT_DT_TRANSMITTANCE = 1u, SLOT_DT_SCALE = 2u;
BASALT_CONST uint SLOT_CD_REFLECTANCE = 0u, SLOT_CD_UROUGH = 1u, SLOT_CD_VROUGH = 2u,
                  SLOT_CD_THICKNESS = 3u, SLOT_CD_ETA = 4u, SLOT_CD_ALBEDO = 5u, SLOT_CD_G = 6u;
BASALT_CONST uint SLOT_CC_IF_UROUGH = 0u, SLOT_CC_IF_VROUGH = 1u, SLOT_CC_THICKNESS = 2u,
                  SLOT_CC_IF_ETA = 3u, SLOT_CC_G = 4u, SLOT_CC_ALBEDO = 5u,
                  SLOT_CC_UROUGH = 6u, SLOT_CC_VROUGH = 7u, SLOT_CC_ETA = 8u, SLOT_CC_K = 9u,
                  SLOT_CC_REFLECTANCE = 10u;
BASALT_CONST uint SLOT_PLASTIC_KD = 0u, SLOT_PLASTIC_KS = 1u, SLOT_PLASTIC_ROUGH = 2u;
BASALT_CONST uint SLOT_SUBSTRATE_KD = 0u, SLOT_SUBSTRATE_KS = 1u, SLOT_SUBSTRATE_UROUGH = 2u,
                  SLOT_SUBSTRATE_VROUGH = 3u;
BASALT_CONST uint SLOT_TRANSLUCENT_KD = 0u, SLOT_TRANSLUCENT_KS = 1u,
                  SLOT_TRANSLUCENT_REFLECT = 2u, SLOT_TRANSLUCENT_TRANSMIT = 3u,
                  SLOT_TRANSLUCENT_ROUGH = 4u;
BASALT_CONST uint SLOT_UBER_KD = 0u, SLOT_UBER_KS = 1u, SLOT_UBER_KR = 2u, SLOT_UBER_KT = 3u,
                  SLOT_UBER_UROUGH = 4u, SLOT_UBER_VROUGH = 5u, SLOT_UBER_ETA = 6u,
                  SLOT_UBER_OPACITY = 7u;
BASALT_CONST uint SLOT_MEASURED_DIMS = 0u;  // xyz: n theta_h, n theta_d, n phi_d (not a texture)
BASALT_CONST uint SLOT_MIX_AMOUNT = 0u;     // MIX: x; MIX_WEIGHTED: rgb. Weight of aux1.
// Every material (docs/bump-spec.md 2): the normal map's MipLevel index as a float in x (never
// a texture), and the displacement (a float slot).
BASALT_CONST uint SLOT_NORMALMAP = 14u, SLOT_DISPLACEMENT = 15u;
// Material.aux0 / aux1: MIX, MIX_WEIGHTED: the two material indices (aux1 gets `amount`);
// COATED_*: maxdepth, nsamples; MEASURED: aux0 = first float of the table in `measured`.

// ---- BSDF lobes (docs/materials-spec.md section 2) ----------------------------------------
// A BSDF at a surface point is a list of up to MAX_LOBES lobes; the probes report these tags.
BASALT_CONST uint MAX_LOBES = 8u;
BASALT_CONST uint LOBE_LAMBERT_R = 1u;
BASALT_CONST uint LOBE_LAMBERT_T = 2u;
BASALT_CONST uint LOBE_OREN_NAYAR = 3u;
BASALT_CONST uint LOBE_MICROFACET_R = 4u;
BASALT_CONST uint LOBE_MICROFACET_T = 5u;
BASALT_CONST uint LOBE_SPECULAR_R = 6u;
BASALT_CONST uint LOBE_SPECULAR_T = 7u;
BASALT_CONST uint LOBE_FRESNEL_BLEND = 8u;
BASALT_CONST uint LOBE_CONDUCTOR = 9u;
BASALT_CONST uint LOBE_DIELECTRIC = 10u;
BASALT_CONST uint LOBE_THIN_DIELECTRIC = 11u;
BASALT_CONST uint LOBE_DIFFUSE_TRANSMISSION = 12u;
BASALT_CONST uint LOBE_LAYERED_DIFFUSE = 13u;
BASALT_CONST uint LOBE_LAYERED_CONDUCTOR = 14u;
BASALT_CONST uint LOBE_MEASURED = 15u;
// Fresnel of LOBE_MICROFACET_R / LOBE_SPECULAR_R
BASALT_CONST uint FRESNEL_ONE = 0u;
BASALT_CONST uint FRESNEL_DIELECTRIC = 1u;
BASALT_CONST uint FRESNEL_CONDUCTOR = 2u;

// BSDF sample flags (pbrt-v4 BxDFFlags values)
BASALT_CONST uint BSDF_REFLECTION = 1u;
BASALT_CONST uint BSDF_TRANSMISSION = 2u;
BASALT_CONST uint BSDF_DIFFUSE = 4u;
BASALT_CONST uint BSDF_GLOSSY = 8u;
BASALT_CONST uint BSDF_SPECULAR = 16u;

// ---- textures (docs/textures-spec.md) ---------------------------------------------------
// A texture is a post-order program: instruction i evaluates textures[i] with the values of
// its children on a small stack; textures[i].first is the first instruction of i's subtree,
// so evaluating texture i runs instructions first .. i. A material slot's texture index is
// the root instruction of its program. Children are pushed in the order listed per tag.
BASALT_CONST uint TEXTURE_CONSTANT = 1u;       // param[0].xyz
BASALT_CONST uint TEXTURE_SCALE = 2u;          // children: tex, scale
BASALT_CONST uint TEXTURE_MIX = 3u;            // children: tex1, tex2, amount
BASALT_CONST uint TEXTURE_DIRECTION_MIX = 4u;  // children: tex1, tex2; param[0].xyz = dir (world)
BASALT_CONST uint TEXTURE_BILERP = 5u;         // param[0..3].xyz = v00, v01, v10, v11
BASALT_CONST uint TEXTURE_CHECKERBOARD = 6u;   // children: tex1, tex2; ip.x = dimension 2 or 3
BASALT_CONST uint TEXTURE_DOTS = 7u;           // children: inside, outside (after pbrt's swap)
BASALT_CONST uint TEXTURE_FBM = 8u;            // ip.x = octaves; param[0].x = roughness
BASALT_CONST uint TEXTURE_WRINKLED = 9u;       // ip.x = octaves; param[0].x = roughness
BASALT_CONST uint TEXTURE_WINDY = 10u;
BASALT_CONST uint TEXTURE_MARBLE = 11u;        // ip.x = octaves; param[0] = (roughness, scale,
                                               //   variation, unused)
BASALT_CONST uint TEXTURE_IMAGEMAP = 12u;      // image = first MipLevel, ip.x = level count;
                                               //   param[0] = (scale, maxanisotropy, 0, 0)
// Shirley's solid textures (seed 002 section 11.1; documented extensions, docs/scene-format.md)
BASALT_CONST uint TEXTURE_STRIPE = 13u;
BASALT_CONST uint TEXTURE_SHIRLEY_NOISE = 14u;
BASALT_CONST uint TEXTURE_SHIRLEY_TURBULENCE = 15u;
BASALT_CONST uint TEXTURE_TURBULENT_STRIPE = 16u;
BASALT_CONST uint TEXTURE_IMAGE_INTERP = 17u;
BASALT_CONST uint TEXTURE_VOLUME = 18u;
BASALT_CONST uint TEXTURE_TYPE_COUNT = 19u;
BASALT_CONST uint MAX_TEXTURE_STACK = 8u;       // deepest value stack a program may need

// Texture.flags: mapping in bits 0-2, image filter in bits 3-5, wrap in bits 6-7, then flags.
BASALT_CONST uint TEXFLAG_MAPPING_MASK = 7u;
BASALT_CONST uint MAPPING_UV = 0u;           // map[0] = (su, sv, du, dv)
BASALT_CONST uint MAPPING_SPHERICAL = 1u;    // xform = texture from world
BASALT_CONST uint MAPPING_CYLINDRICAL = 2u;  // xform = texture from world
BASALT_CONST uint MAPPING_PLANAR = 3u;       // xform; map[0] = (vs, ds), map[1] = (vt, dt)
BASALT_CONST uint MAPPING_POINT3D = 4u;      // 3D textures: xform = texture from world
BASALT_CONST uint TEXFLAG_FILTER_SHIFT = 3u, TEXFLAG_FILTER_MASK = 7u << 3;
BASALT_CONST uint FILTER_POINT = 0u, FILTER_BILINEAR = 1u, FILTER_TRILINEAR = 2u, FILTER_EWA = 3u;
BASALT_CONST uint TEXFLAG_WRAP_SHIFT = 6u, TEXFLAG_WRAP_MASK = 3u << 6;
BASALT_CONST uint WRAP_REPEAT = 0u, WRAP_BLACK = 1u, WRAP_CLAMP = 2u, WRAP_OCTAHEDRAL = 3u;
BASALT_CONST uint TEXFLAG_INVERT = 1u << 8;       // imagemap: 1 - value, clamped at 0
BASALT_CONST uint TEXFLAG_FLOAT = 1u << 9;        // float texture (value broadcast to xyz)
BASALT_CONST uint TEXFLAG_ALBEDO = 1u << 10;      // imagemap in an albedo slot: clamp to [0, 1]

// Globals.texture_opts.x (quality knobs; docs/textures-spec.md 6)
BASALT_CONST uint TEXOPT_DISABLE_FILTERING = 1u << 0;  // Option "disabletexturefiltering"
BASALT_CONST uint TEXOPT_NOISE_SPLIT = 1u << 1;        // noise lookup point split in fp64
BASALT_CONST uint TEXOPT_BUMP_CENTRAL = 1u << 2;       // bump: central differences (bump-spec 4.5)
BASALT_CONST uint TEXOPT_BUMP_NO_DNDU = 1u << 3;       // bump: drop the d dn/du term (bump-spec 4.5)
// Globals.texture_opts.w: shading options
BASALT_CONST uint SHADEOPT_PBRT_V4_SIDES = 1u << 0;
// Globals.render_opts (path-spec 7.1), all zero by default (pbrt-v4's behaviour): x = when
// Russian roulette may end a path: 0 once it has bounced more than once (pbrt-v4), N + 1 once
// it has bounced more than N times, ROULETTE_OFF never; y = the MIS mode of light and BSDF
// sampling.
BASALT_CONST uint ROULETTE_OFF = 0xffffffffu;
BASALT_CONST uint MIS_POWER = 0u;      // Veach's power heuristic, beta 2 (pbrt-v4)
BASALT_CONST uint MIS_BALANCE = 1u;    // the balance heuristic
BASALT_CONST uint MIS_BSDF_ONLY = 2u;  // BSDF sampling alone (no next-event estimation)
BASALT_CONST uint MIS_LIGHT_ONLY = 3u; // light sampling alone (BSDF-sampled hits on lights
                                       // count only after specular bounces and camera rays)  // the shading frame alone decides reflection
                                                    // or transmission (pbrt-v4; materials-spec 1.2)

// Globals.sampler_opts.x: the sampler (docs/sampler-spec.md 3); y: its randomisation.
BASALT_CONST uint SAMPLER_INDEPENDENT = 0u;
BASALT_CONST uint SAMPLER_STRATIFIED = 1u;
BASALT_CONST uint SAMPLER_HALTON = 2u;
BASALT_CONST uint SAMPLER_PADDED_SOBOL = 3u;
BASALT_CONST uint SAMPLER_ZSOBOL = 4u;
BASALT_CONST uint SAMPLER_SOBOL = 5u;
BASALT_CONST uint SAMPLER_PMJ02BN = 6u;
BASALT_CONST uint RAND_NONE = 0u;
BASALT_CONST uint RAND_PERMUTE = 1u;
BASALT_CONST uint RAND_FASTOWEN = 2u;
BASALT_CONST uint RAND_OWEN = 3u;
BASALT_CONST uint SAMPLER_PRIME_COUNT = 1000u;  // primes at the start of sampler_data
// Tables of the sobol and pmj02bn samplers in sampler_data, after the primes (sampler-spec 3).
BASALT_CONST uint SAMPLER_TABLES = SAMPLER_PRIME_COUNT;  // offset of the first table
BASALT_CONST uint SOBOL_DIMENSIONS = 1024u;  // Sobol' dimensions (Joe & Kuo 2008 for 1..1023)
BASALT_CONST uint SOBOL_COLUMNS = 52u;       // generator-matrix columns: indices below 2^52
BASALT_CONST uint SOBOL_INVERSE = SAMPLER_TABLES + SOBOL_DIMENSIONS * SOBOL_COLUMNS;
BASALT_CONST uint PMJ_SETS = 5u;             // pmj02bn point sets
BASALT_CONST uint PMJ_SAMPLES = 65536u;      // points per set (the spp limit of pmj02bn)
BASALT_CONST uint PMJ_PIXEL_TABLE = SAMPLER_TABLES + 2u * PMJ_SETS * PMJ_SAMPLES;

// Offsets into tex_data of the shared tables (Globals.tex_tables), docs/textures-spec.md 5.
// tex_tables.x: noise permutation (512 floats holding integers), y: EWA weight table
// (EWA_LUT_SIZE floats), z: Shirley gradients (256 x 3 floats) and permutation (256), w: unused.
BASALT_CONST uint EWA_LUT_SIZE = 128u;

// ---- light tags ------------------------------------------------------------------------
BASALT_CONST uint LIGHT_POINT = 1u;
BASALT_CONST uint LIGHT_SPOT = 2u;
BASALT_CONST uint LIGHT_DISTANT = 3u;
BASALT_CONST uint LIGHT_INFINITE_UNIFORM = 4u;
BASALT_CONST uint LIGHT_AREA_TRIANGLE = 5u;
BASALT_CONST uint LIGHT_AREA_SPHERE = 6u;
BASALT_CONST uint LIGHT_INFINITE_IMAGE = 7u;  // equal-area octahedral image (pbrt-v4)
BASALT_CONST uint LIGHT_FLAG_TWOSIDED = 1u;
BASALT_CONST uint MAX_INFINITE_LIGHTS = 4u;
// Light selection (Globals.light_opts.x; docs/path-spec.md 6): by the light cdf alone, or with
// the bounded lights re-picked by their importance at the shading point (6.1).
BASALT_CONST uint LIGHT_SELECT_CDF = 0u;
BASALT_CONST uint LIGHT_SELECT_IMPORTANCE = 1u;
// "bvh" picks by importance when at most this many bounded lights have power (6.1).
BASALT_CONST uint LIGHT_IMPORTANCE_MAX_BVH = 16u;
// Cap on one light's importance, so that a sum over lights stays finite (6.1).
BASALT_CONST float LIGHT_IMPORTANCE_CAP = 1e30f;

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
  uvec4 features;          // x, y: feature words of the scene (the specialization constants)
  // Pixel footprint (pbrt-v4 Camera::Approximate_dp_dxy, docs/textures-spec.md 3): the
  // camera-space minimum position and direction differentials, w of min_dir_dx = the spp scale
  // max(1/8, 1/sqrt(spp)) that pbrt-v4 applies to every differential.
  vec4 min_pos_dx;
  vec4 min_pos_dy;
  vec4 min_dir_dx;
  vec4 min_dir_dy;
  uvec4 texture_opts;      // x: TEXOPT_* bits, y: octave cap (0: none), z: fixed bump step
                           // (float bits; 0: from the footprint, bump-spec 4.5), w: SHADEOPT_*
  uvec4 tex_tables;        // offsets into tex_data (see EWA_LUT_SIZE above)
  mat4 camera_from_world;  // inverse of world_from_camera (Approximate_dp_dxy)
  uvec4 render_opts;       // x: roulette (0: pbrt-v4's; see ROULETTE_OFF), y: MIS_*, z, w: unused
  uvec4 sampler_opts;      // x: SAMPLER_*, y: RAND_* (stratified: jitter 1/0), z, w: n0, n1
  uvec4 sampler_params;    // type-specific (docs/sampler-spec.md 3)
  uvec4 light_opts;        // x: LIGHT_SELECT_*, y: float bits of the bounded lights' total pmf
                           // (1 - p_inf, path-spec 6.1), z, w: unused
};

/// BVH node: interior when b == 0 (children at a and a+1), else leaf over prim_refs[a, a+b).
struct BvhNode {
  vec3 lo;
  uint a;
  vec3 hi;
  uint b;
};

/// Wide BVH node of the GPU's traversal (docs/path-spec.md 3.1): the binary BVH collapsed to
/// four children a node (the grandchildren of a binary node), each child's box quantised to 8
/// bits an axis against the node: child i spans origin + q * 2^(e - 127) per axis, q = byte i
/// of qlo / qhi, e = byte k of exponents for axis k. Boxes are rounded outwards, so they contain
/// the binary boxes. child[i]: a wide node index, BVH_WIDE_LEAF | (count - 1) << 26 | first
/// prim_refs entry, or INVALID_INDEX for an empty slot. Built by build_wide_bvh (host/accel).
struct BvhWideNode {
  vec3 origin;
  uint exponents;
  uvec4 qlo;  // x, y, z: per axis, byte i = child i; w: 0
  uvec4 qhi;
  uvec4 child;
};
BASALT_CONST uint BVH_WIDE_LEAF = 0x80000000u;
BASALT_CONST uint BVH_WIDE_LEAF_MAX = 32u;             // prims a wide leaf holds at most
BASALT_CONST uint BVH_WIDE_FIRST_LIMIT = 0x4000000u;   // first prim_refs entry < 2^26
BASALT_CONST uint BVH_WIDE_STACK = 96u;  // 3 entries a level, at most 32 levels (bvh.h)

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
  vec4 axis_x;         // object x, y, z axes in world space, unit length; axis_x.w = the
                       // object-to-world scale (docs/textures-spec.md 3.2)
  vec4 axis_y;
  vec4 axis_z;
  uint material;
  uint light;  // INVALID_INDEX when not emissive
  uint flags;  // SHAPE_FLAG_*
  uint pad0;
};

/// Material: a type tag and parameter slots; each slot is a constant or a texture.
struct Material {
  uint type;        // MATERIAL_*
  uint flags;       // MATFLAG_*
  uint aux0;        // per type, see MATERIAL_* above
  uint aux1;
  vec4 value[16];   // constant value of each slot (MATERIAL_SLOTS)
  uvec4 texture[4]; // texture index of slot i at texture[i / 4][i % 4]; INVALID_INDEX = constant
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
  uvec4 data;  // LIGHT_INFINITE_IMAGE: x = MipLevel of the image (level 0), y = offset in
               // tex_data of its sampling distribution, z = of the MIS-compensated one
  mat4 light_from_world;  // LIGHT_INFINITE_IMAGE: rotation into the light's frame
  // Bounds for importance (docs/path-spec.md 6.1; pbrt-v4 LightBounds) of a bounded light:
  vec4 bound_c;  // xyz: centre of its box, w: phi (0: never picked by importance)
  vec4 bound_w;  // xyz: unit axis of its emission cone, w: cos(theta_o)
  vec4 bound_e;  // x: half the box's diagonal, y: cos(theta_e), z, w: unused
};

/// Texture instruction (docs/textures-spec.md section 2).
struct Texture {
  uint type;    // TEXTURE_*
  uint flags;   // TEXFLAG_* (mapping, filter, wrap, ...)
  uint first;   // first instruction of this texture's program
  uint image;   // IMAGEMAP: index of its first MipLevel
  uvec4 ip;     // integer parameters (per tag)
  vec4 param[4];
  vec4 map[2];  // mapping parameters
  mat4 xform;   // texture space from world (spherical, cylindrical, planar, 3D)
};

/// One level of an image pyramid in texels[]: width x height texels of `channels` floats.
struct MipLevel {
  uint offset;
  uint width;
  uint height;
  uint channels;  // 1 or 3
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

// ---- wavefront stages (shaders/wavefront.comp, docs/performance.md) ----------------------
// The paths of a wave live in BINDING_PROBE_IN (WF_PATH_VEC4S vec4 each: the integrator's
// PathState and the hit of its ray); BINDING_PROBE_OUT holds WF_COUNTERS counter words, then
// WF_LISTS lists of path indices of `capacity` entries each (PassConstants.pad1): the active
// lists 0 and 1 (the paths still going, written by the shade stages of one iteration, read by
// the extend stage of the next) and a queue per material type (written by the extend stage,
// read by that type's shade pipeline), and in a scene with an image infinite light the escape
// list (the paths whose ray left the scene, written by the extend stage, read by the escape
// stage). Counter k counts the entries of list k. After the
// lists, WF_RADIANCE_WORDS words a path: the radiance of the path when it ended (three float
// bit patterns) and its pixel's index (INVALID_INDEX for a slot that started no path), which
// the host adds to the pixel after the wave, in the order of the paths (so in sample order).
// A wave runs up to `capacity` (sample, slot) pairs in order, from slot pixel_offset of
// sample sample_start: path id takes pair pixel_offset + id (slot that % pixel_total of
// sample sample_start + that / pixel_total), so a small image's wave holds several samples.
// PassConstants of a stage: sample_start the wave's first sample, sample_count the
// iteration, pixel_offset its first slot, pixel_count the invocations, pad0 the list or queue
// it reads (a shade stage: queue | parity << 16, the active list it appends to), pad1 the
// capacity.
BASALT_CONST uint WF_PATH_VEC4S = 12u;
BASALT_CONST uint WF_COUNTERS = 32u;
BASALT_CONST uint WF_LIST_QUEUE = 2u;  // list WF_LIST_QUEUE + t: the queue of MATERIAL_* t
BASALT_CONST uint WF_LIST_ESCAPE = WF_LIST_QUEUE + MATERIAL_TYPE_COUNT;  // escaped paths
BASALT_CONST uint WF_LISTS = WF_LIST_ESCAPE + 1u;
BASALT_CONST uint WF_RADIANCE_WORDS = 4u;

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
// PROBE_BSDF: one BSDF query (docs/materials-spec.md section 6) on material key.y of the
// probe scene, at the surface point p = (o_tmax.w, d.w, extra.w) with shading frame = world
// frame (ns = +z, dpdu = +x), in local directions:
//   in:  o_tmax.xyz = wo, d.xyz = wi, extra.xyz = u (lobe, u0, u1), extra2.xyz = ng (local),
//        key.z, key.w = stream key (px, py); streams use sample 0 and dims 7, 8, 9, 10
//   out: f0 = (bsdf_eval(wo, wi) rgb, bsdf_pdf(wo, wi))    [eval stream dim 7, pdf dim 8]
//        f1 = (sample f rgb, sample pdf)                     [sample stream dim 9]
//        f2 = (sample wi xyz, sample eta)
//        f3 = (bsdf_pdf(wo, sample wi) [stream dim 10], lobe count, 0, 0)
//        u  = (sample flags (0: no sample), bsdf_flags (union of lobe flags),
//              sample pdf_is_proportional, lobe tag of lobe 0)
BASALT_CONST uint PROBE_BSDF = 6u;
// PROBE_TEXTURE: tex_eval_rgb (key.z = 0) or tex_eval_float (key.z = 1) of texture key.y in
// the context  p = o_tmax.xyz, uv = (o_tmax.w, d.w), n = d.xyz, dpdx = extra.xyz,
// dpdy = extra2.xyz, dudx = extra.w, dudy = extra2.w, dvdx = extra3.x, dvdy = extra3.y
//   out: f0.xyz = value (float: x, y and z equal)
BASALT_CONST uint PROBE_TEXTURE = 7u;
// PROBE_NOISE: noise functions at p = o_tmax.xyz (key.y = 0: pbrt perlin_noise; 1: Shirley's
// solid noise; 2: pbrt fbm with dpdx = d.xyz, dpdy = extra.xyz, octaves key.z, roughness
// extra.w; 3: pbrt turbulence, same inputs; 4: Shirley's turbulence with key.z octaves;
// 5: perlin noise at lambda p with lambda = extra.w); key.w = 1 uses the split-precision
// lookup (ops 2, 3, 5; docs/textures-spec.md 2.1)
//   out: f0.x = value
BASALT_CONST uint PROBE_NOISE = 8u;
// PROBE_ENV: image infinite light key.y; in: d.xyz = world direction, extra.xy = u (sample)
//   out: f0 = (Le(d) rgb, pdf(d)), f1 = (sampled wi xyz, pdf), f2 = (sampled Li rgb, 0),
//        f3.x = pdf of the MIS-compensated distribution at d
BASALT_CONST uint PROBE_ENV = 9u;
// PROBE_DIFFERENTIALS: texture context at the first hit of the camera ray of pixel
// (key.z, key.w), sample floatBitsToUint(extra.x) (docs/textures-spec.md 3): key.y = 0: with
// the camera ray's differentials (bounce 0); 1: as at a later bounce (Approximate_dp_dxy);
// 2: at the hit of the ray perfectly reflected about the first hit's shading normal ns
// (wi = 2 dot(wo, ns) ns - wo) carrying specular_differentials (3.1); 3: likewise refracted
// with relative IOR extra.y (pbrt-v4 Refract; total internal reflection: no second ray)
//   out: f0 = (dpdx, dudx), f1 = (dpdy, dudy), f2 = (uv, dvdx, dvdy), f3.xyz = p; u.x = prim
//        (of the second hit for modes 2, 3: u.y = 1 when the second ray carried differentials)
BASALT_CONST uint PROBE_DIFFERENTIALS = 10u;
// PROBE_BUMP: the first hit of the camera ray of pixel (key.z, key.w), sample
// floatBitsToUint(extra.x), its material after mix resolution (wo = -d), then bump_shading
// (docs/bump-spec.md 6)
// (key.y = 0); or (key.y = 1) bump_shading of material key.z at a synthetic surface point:
// p = o_tmax.xyz, uv = (o_tmax.w, d.w), ng = d.xyz, ns = extra3.xyz, shading pair
// (extra.xyz, extra2.xyz), footprint dudx = dudy = extra.w, dvdx = dvdy = extra2.w,
// dpdx = dpdy = 0, dndu = extra3.w * extra.xyz, dndv = extra3.w * extra2.xyz, the shading
// frame shading_frame(ns, extra.xyz) (u.x = 0)
//   out: f0.xyz = the shading normal, f1.xyz = dpdu', f2.xyz = dpdv' (the unbumped shading
//        pair of bump-spec 3 when no bump applies), f3.xyz = the shading frame's t1;
//        u.x = prim, u.y = 1 when a bump or normal map changed the frame
BASALT_CONST uint PROBE_BUMP = 11u;
// PROBE_SAMPLER: sampler_get(px, py, s, d) of the scene's sampler (docs/sampler-spec.md 4);
// in: key.yzw = px, py, s; extra.x = d (as uint bits) -> out: f0.x = the value
BASALT_CONST uint PROBE_SAMPLER = 12u;

/// One probe query.
struct ProbeIn {
  uvec4 key;    // x: PROBE_* op; y, z, w: op arguments
  vec4 o_tmax;  // ray origin, tMax
  vec4 d;       // ray direction (xyz)
  vec4 extra;   // op-specific
  vec4 extra2;  // op-specific
  vec4 extra3;  // op-specific
};

/// One probe answer. Misses report prim INVALID_INDEX and t = -1.
struct ProbeOut {
  vec4 f0;   // CLOSEST/RESPAWN: t, b1, b2, unused
  vec4 f1;   // RESPAWN: second hit t, b1, b2, unused
  vec4 f2;   // op-specific
  vec4 f3;   // op-specific
  uvec4 u;   // x: prim of first hit (or occluded flag), y: prim of second hit
};

// ---- the trace stage (shaders/trace.comp, GpuRenderer::trace): rays in, hits out ---------
// One invocation per ray (BINDING_PROBE_IN / BINDING_PROBE_OUT of its own pipeline);
// PassConstants.pixel_count is the ray count and pad0 = 1 asks for any hit (shadow rays).

/// A ray: origin and tMax, direction (w unused).
struct TraceRay {
  vec4 o_tmax;
  vec4 d;
};

/// Its hit: t (-1 for a miss), barycentrics b1, b2 of v1, v2, and the prim reference
/// (INVALID_INDEX for a miss; an any-hit query reports the first hit it finds).
struct TraceHit {
  float t;
  float b1;
  float b2;
  uint prim;
};

#ifdef __cplusplus
static_assert(sizeof(TraceRay) == 32 && sizeof(TraceHit) == 16, "Trace layout");
static_assert(sizeof(ProbeIn) == 96 && sizeof(ProbeOut) == 80, "Probe layout");
static_assert(sizeof(Globals) == 64 + 4 * 16 + 4 * 16 + 6 * 16 + 64 + 4 * 16, "Globals layout");
static_assert(sizeof(BvhNode) == 32 && offsetof(BvhNode, hi) == 16, "BvhNode layout");
// shaders/include/bsdf.glsl (bsdf_lobe, lobe_add) spells out one case per lobe of the list.
static_assert(MAX_LOBES == 8u, "bsdf.glsl lists eight lobe cases");
static_assert(sizeof(BvhWideNode) == 64 && offsetof(BvhWideNode, qlo) == 16, "BvhWideNode layout");
static_assert(sizeof(Triangle) == 16, "Triangle layout");
static_assert(sizeof(Vertex) == 32, "Vertex layout");
static_assert(sizeof(Mesh) == 16, "Mesh layout");
static_assert(sizeof(Sphere) == 80 && offsetof(Sphere, material) == 64, "Sphere layout");
static_assert(sizeof(Material) == 336 && offsetof(Material, texture) == 272, "Material layout");
static_assert(sizeof(Light) == 208 && offsetof(Light, L) == 16 &&
              offsetof(Light, light_from_world) == 96 && offsetof(Light, bound_c) == 160,
              "Light layout");
static_assert(sizeof(Texture) == 192 && offsetof(Texture, param) == 32 &&
              offsetof(Texture, xform) == 128, "Texture layout");
static_assert(sizeof(MipLevel) == 16, "MipLevel layout");
static_assert(sizeof(PassConstants) == 32, "PassConstants layout");
static_assert(WF_COUNTERS >= WF_LISTS, "a counter for every wavefront list");
}  // namespace basalt::gpu
#endif

#endif  // BASALT_LAYOUT_H
