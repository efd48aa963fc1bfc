// Camera rays with pbrt-v4 conventions (docs/path-spec.md section 2). Needs bindings.glsl.
#ifndef BASALT_CAMERA_GLSL
#define BASALT_CAMERA_GLSL

#include "math.glsl"
#include "rng.glsl"
#include "sampler.glsl"
#include "sampling.glsl"

// A camera ray and its differentials (the rays through the film point one pixel to the
// right and one pixel down, with the same lens sample; pbrt-v4 PerspectiveCamera).
struct CameraRay {
  vec3 o;
  vec3 d;
  vec3 rx_o;
  vec3 rx_d;
  vec3 ry_o;
  vec3 ry_d;
};

// Offset in [-r, r] sampled from the tabulated 1D gaussian filter distribution whose
// cdf[0..n] starts at filter_cdf[base] (docs/path-spec.md section 2 step 1; pbrt-v4
// FilterSampler). Bin i is the largest index with cdf[i] <= u.
float filter_sample_axis(float u, uint base, uint n, float r) {
  uint lo = 0u, hi = n;
  // The end tested at the end of a pass (a loop's closing test costs lavapipe a pass).
  if (hi - lo > 1u) while (true) {
    uint mid = (lo + hi) / 2u;
    if (filter_cdf[base + mid] <= u) lo = mid; else hi = mid;
    if (hi - lo <= 1u) break;
  }
  float c0 = filter_cdf[base + lo];
  float width = filter_cdf[base + lo + 1u] - c0;
  float du = width > 0.0 ? (u - c0) / width : 0.0;
  return -r + 2.0 * r * (float(lo) + du) / float(n);
}

// Filter offset of the sample within its pixel for the filter dimensions' values (ux, uy)
// (box or gaussian; weight 1 in both cases).
vec2 filter_offset(float ux, float uy) {
  vec2 r = globals.filter_radius.xy;
  if (has_feature(FEATURE_FILTER_GAUSSIAN) && globals.counts.z == FILTER_GAUSSIAN) {
    uint n = globals.counts.w;
    if (n == 0u) return vec2(0.0);  // no table (malformed input): the pixel centre
    return vec2(filter_sample_axis(ux, 0u, n, r.x), filter_sample_axis(uy, n + 1u, n, r.y));
  }
  return vec2((ux - 0.5) * 2.0 * r.x, (uy - 0.5) * 2.0 * r.y);
}

// World-space ray through film point p_film (pixels) and lens point p_lens (camera space,
// zero for a pinhole), steps 3 to 5 of docs/path-spec.md section 2.
void camera_ray_through(vec2 p_film, vec2 p_lens, out vec3 o, out vec3 d) {
  vec4 scr = globals.screen;  // xmin, xmax, ymin, ymax
  float sx = scr.x + p_film.x / float(globals.image.x) * (scr.y - scr.x);
  float sy = scr.w - p_film.y / float(globals.image.y) * (scr.w - scr.z);
  float tan_half = globals.lens.x;
  vec3 dc = vec3(sx * tan_half, sy * tan_half, 1.0);
  vec3 oc = vec3(0.0);
  vec3 dir = safe_normalize(dc);
  if (has_feature(FEATURE_THIN_LENS) && globals.lens.y > 0.0) {
    // pbrt-v4 PerspectiveCamera: the focal plane is z = focal distance, pFocus = dc * fd.
    oc = vec3(p_lens, 0.0);
    dir = safe_normalize(dc * globals.lens.z - oc);
  }
  // Transforms spelled out so that the summation order is fixed (glm's: pairwise for mat4 x
  // vec4, left to right for mat3 x vec3) and the CPU reference rounds the same.
  mat4 m = globals.world_from_camera;
  o = (m[0].xyz * oc.x + m[1].xyz * oc.y) + (m[2].xyz * oc.z + m[3].xyz);
  d = safe_normalize(m[0].xyz * dir.x + m[1].xyz * dir.y + m[2].xyz * dir.z);
}

// Camera ray of sample s of pixel (px, py) (docs/path-spec.md section 2), with its
// differential rays if diffs (else they repeat the ray).
CameraRay camera_ray(uint px, uint py, uint s, bool diffs) {
  bool thin_lens = has_feature(FEATURE_THIN_LENS) && globals.lens.y > 0.0;
  vec4 u = camera_samples(px, py, s, thin_lens ? 4u : 2u);  // filter, lens
  vec2 p_film = vec2(float(px) + 0.5, float(py) + 0.5) + filter_offset(u.x, u.y);
  vec2 p_lens = vec2(0.0);
  if (thin_lens) p_lens = globals.lens.y * concentric_disk(u.zw);
  CameraRay cr;
  camera_ray_through(p_film, p_lens, cr.o, cr.d);
  if (diffs) {
    camera_ray_through(p_film + vec2(1.0, 0.0), p_lens, cr.rx_o, cr.rx_d);
    camera_ray_through(p_film + vec2(0.0, 1.0), p_lens, cr.ry_o, cr.ry_d);
  } else {
    cr.rx_o = cr.ry_o = cr.o;
    cr.rx_d = cr.ry_d = cr.d;
  }
  return cr;
}

// Pixel of invocation slot i (docs/path-spec.md section 9): lane i % 64 of tile i / 64, the
// tiles shuffled as tile' = (tile * stride) % ntiles with ntiles = total / 64 (total: the
// tile-padded slot count; the host keeps (ntiles - 1) * stride below 2^32). False for a slot
// of the padding past the image's edge.
bool slot_pixel(uint i, uint stride, uint total, out uint px, out uint py) {
  uint tile = i / 64u;
  uint lane = i % 64u;
  uint shuffled = (tile * stride) % (total / 64u);
  uint tiles_x = (globals.image.x + 7u) / 8u;
  px = (shuffled % tiles_x) * 8u + lane % 8u;
  py = (shuffled / tiles_x) * 8u + lane / 8u;
  return px < globals.image.x && py < globals.image.y;
}

#endif
