// Bump and normal mapping (docs/bump-spec.md; pbrt-v4 materials.h BumpMap / NormalMap and
// interaction.cpp SurfaceInteraction::GetBSDF with SetShadingGeometry(..., false)). The CPU twin
// is host/cpu/bump.cpp (same function names). Needs bindings.glsl.
//
// Compile-time note (see bsdf.glsl): the displacement texture is evaluated at its three
// contexts by slots_resolve's one texture-interpreter loop (two extra iterations take the
// shifted contexts of bump_shifted_ctx); bump_map only combines the three values. Everything
// here is gated by FEATURES2 & (FEATURE2_BUMP | FEATURE2_NORMALMAP | FEATURE2_VTURB), so scenes
// without bump or normal maps or vector turbulence compile it away.
#ifndef BASALT_BUMP_GLSL
#define BASALT_BUMP_GLSL

#include "math.glsl"
#include "sampling.glsl"
#include "mipmap.glsl"
#include "surface.glsl"
#include "noise.glsl"

// True if the scene may bump (FEATURE2_BUMP) or normal-map (FEATURE2_NORMALMAP), and if it
// may perturb normals by vector turbulence (FEATURE2_VTURB, bump-spec 9). False as written in
// the plain builds, whose scenes have none of them (bindings.glsl: a specialization constant
// would leave the code they guard for the scene-time specialisation to remove).
#ifdef BASALT_PLAIN
const bool BUMP_ENABLED = false;
const bool NORMALMAP_ENABLED = false;
const bool VTURB_ENABLED = false;
#else
const bool BUMP_ENABLED = feature2_const(FEATURE2_BUMP);
const bool NORMALMAP_ENABLED = feature2_const(FEATURE2_NORMALMAP);
const bool VTURB_ENABLED = feature2_const(FEATURE2_VTURB);
#endif

// True if material flags `mflags` ask for the bump of bump-spec 4 (a displacement and no
// normal map: the normal map wins, bump-spec 1).
bool bump_wanted(uint mflags) {
  return BUMP_ENABLED && (mflags & MATFLAG_BUMP) != 0u &&
         !(NORMALMAP_ENABLED && (mflags & MATFLAG_NORMALMAP) != 0u);
}

// True if the bump takes central differences (bump-spec 4.5, TEXOPT_BUMP_CENTRAL).
bool bump_central() { return (globals.texture_opts.x & TEXOPT_BUMP_CENTRAL) != 0u; }

// The steps du, dv of bump-spec 4.1 (pbrt-v4 BumpMap): half the summed |footprint| in u and
// v, 0.0005 where that is 0; or the fixed step of bump-spec 4.5 (Globals.texture_opts.z).
vec2 bump_steps(TexCtx c) {
  float fixed_step = uintBitsToFloat(globals.texture_opts.z);
  if (fixed_step > 0.0) return vec2(fixed_step);
  precise float du = 0.5 * (abs(c.dudx) + abs(c.dudy));
  precise float dv = 0.5 * (abs(c.dvdx) + abs(c.dvdy));
  if (du == 0.0) du = 0.0005;
  if (dv == 0.0) dv = 0.0005;
  return vec2(du, dv);
}

// The shifted texture context of bump-spec 4.2: k = 0 gives cu (p + du sdpdu, uv + (du, 0)),
// k = 1 gives cv (p + dv sdpdv, uv + (0, dv)), k = 2 and 3 the backward contexts of central
// differences (4.5: steps -du, -dv); the rest of sp.tex unchanged.
TexCtx bump_shifted_ctx(SurfacePoint sp, uint k) {
  vec2 st = bump_steps(sp.tex);
  TexCtx c = sp.tex;
  float h = (k & 1u) == 0u ? st.x : st.y;
  if (k >= 2u) h = -h;
  vec3 dir = (k & 1u) == 0u ? sp.sdpdu : sp.sdpdv;
  precise vec3 p = c.p + h * dir;
  precise vec2 uv = c.uv + ((k & 1u) == 0u ? vec2(h, 0.0) : vec2(0.0, h));
  c.p = p;
  c.uv = uv;
  return c;
}

// dpdu' = (a + s n) + d b as bump-spec 4.4 writes it (left to right, no fma); without the
// d b term when !dndu (bump-spec 4.5).
vec3 bump_combine(vec3 a, float s, vec3 n, float d, vec3 b, bool dndu) {
  precise vec3 r = a + s * n;
  precise vec3 rb = r + d * b;
  return dndu ? rb : r;
}

// The slope (hi - lo) / h of a finite difference, no fma.
float bump_slope(float hi, float lo, float h) {
  precise float s = (hi - lo) / h;
  return s;
}

// The bumped shading pair of bump-spec 4 (pbrt-v4 BumpMap) from the displacement at the hit
// (disp) and at the shifted contexts of bump_shifted_ctx (disp_uv: cu, cv, and for central
// differences the backward ones), with the knobs of bump-spec 4.5.
void bump_map(SurfacePoint sp, float disp, vec4 disp_uv, out vec3 dpdu, out vec3 dpdv) {
  vec2 st = bump_steps(sp.tex);
  float su, sv;
  if (bump_central()) {
    precise vec2 two = st + st;
    su = bump_slope(disp_uv.x, disp_uv.z, two.x);
    sv = bump_slope(disp_uv.y, disp_uv.w, two.y);
  } else {
    su = bump_slope(disp_uv.x, disp, st.x);
    sv = bump_slope(disp_uv.y, disp, st.y);
  }
  bool dndu = (globals.texture_opts.x & TEXOPT_BUMP_NO_DNDU) == 0u;
  dpdu = bump_combine(sp.sdpdu, su, sp.ns, disp, sp.dndu, dndu);
  dpdv = bump_combine(sp.sdpdv, sv, sp.ns, disp, sp.dndv, dndu);
}

// Bilinear weight products of pbrt-v4 Image::BilerpChannel: ((1-dx)(1-dy), dx(1-dy),
// (1-dx)dy, dx dy).
vec4 normal_map_weights(float dx, float dy) {
  precise float ex = 1.0 - dx;
  precise float ey = 1.0 - dy;
  precise vec4 w = vec4(ex * ey, dx * ey, ex * dy, dx * dy);
  return w;
}

// a x + b y + c z summed left to right, no fma (a frame's FromLocal).
vec3 frame_from_local(vec3 a, vec3 b, vec3 c, vec3 l) {
  precise vec3 r = a * l.x + b * l.y + c * l.z;
  return r;
}

// v - dot(v, n) n (Gram-Schmidt), no fma.
vec3 gram_schmidt(vec3 v, vec3 n) {
  float d = dot_exact(v, n);
  precise vec3 r = v - d * n;
  return r;
}

// The pair of bump-spec 5.4 that gives the unit normal nw, with the lengths of (a, b):
// a' = normalize(a - dot(a, nw) nw) |a|, b' = normalize(cross(nw, a')) |b|.
void normal_pair(vec3 a, vec3 b, vec3 nw, out vec3 dpdu, out vec3 dpdv) {
  float ulen = sqrt(dot_exact(a, a));
  float vlen = sqrt(dot_exact(b, b));
  vec3 gs = gram_schmidt(a, nw);
  dpdu = (gs / sqrt(dot_exact(gs, gs))) * ulen;
  vec3 cr = cross_exact(nw, dpdu);
  dpdv = (cr / sqrt(dot_exact(cr, cr))) * vlen;
}

// The normal-mapped shading pair of bump-spec 5 (pbrt-v4 NormalMap) from MipLevel `level`
// (level 0 of the normal map, 3 channels); false (no normal map at this hit) where the tangent
// normal is zero or not finite or sdpdu is zero (bump-spec 5.2, 5.3).
bool normal_map(SurfacePoint sp, uint level, out vec3 dpdu, out vec3 dpdv) {
  dpdu = sp.sdpdu;
  dpdv = sp.sdpdv;
  // 5.1: bilinear lookup at (u, 1 - v), repeat wrap (pbrt-v4 Image::BilerpChannel).
  MipLevel ml = mip_level_at(level);
  precise float t = 1.0 - sp.tex.uv.y;
  precise float x = sp.tex.uv.x * float(ml.width) - 0.5;
  precise float y = t * float(ml.height) - 0.5;
  // basalt guard (bump-spec is silent): a coordinate beyond int range has no texel.
  if (!(abs(x) < 1073741824.0 && abs(y) < 1073741824.0)) return false;
  float fx = floor(x), fy = floor(y);
  precise float dx = x - fx;
  precise float dy = y - fy;
  ivec2 xy = ivec2(int(fx), int(fy));
  vec4 w = normal_map_weights(dx, dy);
  precise vec3 rgb = vec3(0.0);
  // One texel read site (code size): texels (xi, yi), (xi+1, yi), (xi, yi+1), (xi+1, yi+1).
  {  // the end tested at the end of a pass (a for loop's closing test costs lavapipe a pass)
    uint k = 0u;
    [[dont_unroll]] while (true) {
      vec3 tx = mipmap_texel(level, xy + ivec2(int(k & 1u), int(k >> 1u)), WRAP_REPEAT, false);
      rgb = k == 0u ? w[0] * tx : rgb + w[k] * tx;
      if (++k >= 4u) break;
    }
  }
  // 5.2: the tangent-space normal.
  precise vec3 nt = 2.0 * rgb - vec3(1.0);
  float l2 = dot_exact(nt, nt);
  if (!(l2 > 0.0) || isinf(l2)) return false;
  nt = nt / sqrt(l2);
  // 5.3: pbrt-v4 Frame::FromXZ(normalize(sdpdu), ns).
  float u2 = dot_exact(sp.sdpdu, sp.sdpdu);
  if (u2 == 0.0) return false;
  vec3 fx_ = sp.sdpdu / sqrt(u2);
  vec3 fy_ = cross_exact(sp.ns, fx_);
  vec3 nw = frame_from_local(fx_, fy_, sp.ns, nt);
  // 5.4: the pair that gives nw, with the lengths of the unbumped one.
  normal_pair(sp.sdpdu, sp.sdpdv, nw, dpdu, dpdv);
  return true;
}

// m = n0 + k1 v of bump-spec 9.2 (k1 v first, then the sum; no fma).
vec3 vturb_offset(vec3 n0, float k1, vec3 v) {
  precise vec3 m = n0 + k1 * v;
  return m;
}

// The scaled lookup point q = k2 p of bump-spec 9.1 (one product per component).
vec3 vturb_point(float k2, vec3 p) {
  precise vec3 q = k2 * p;
  return q;
}

// The vector-turbulence pair of bump-spec 9.1-9.3 (Shirley's n += k1 vectorTurbulence(k2 p))
// from the shading normal n0 and pair (a, b) after the bump or normal map, at the texture
// context's point p: false (nothing changes) where m = n0 + k1 v is below FLT_MIN in squared
// length or not finite, or a is.
bool vturb_pair(vec3 n0, vec3 a, vec3 b, vec3 p, float k1, float k2, int octaves,
                out vec3 dpdu, out vec3 dpdv) {
  dpdu = a;
  dpdv = b;
  vec3 v = vector_turbulence(vturb_point(k2, p), octaves);
  vec3 m = vturb_offset(n0, k1, v);
  float m2 = dot_exact(m, m);
  if (!(m2 >= FLT_MIN) || isinf(m2)) return false;
  vec3 nw = m / sqrt(m2);
  if (dot_exact(a, a) < FLT_MIN) return false;
  normal_pair(a, b, nw, dpdu, dpdv);
  return true;
}

// The shading geometry after a bump, normal map or vector turbulence (docs/bump-spec.md 6.4,
// 9): normal, frame (t1, t2) and the pair (dpdu', dpdv') (pbrt-v4 shading.n, shading.dpdu,
// shading.dpdv).
struct BumpFrame {
  vec3 ns;
  vec3 t1;
  vec3 t2;
  vec3 dpdu;
  vec3 dpdv;
};

// The normal of the new pair (dpdu, dpdv) as bump-spec 6.2-6.3 (pbrt-v4
// SetShadingGeometry(ns, dpdu, dpdv, dndu, dndv, false)): n = normalize(cross(dpdu, dpdv))
// face-forwarded to ng. False where n is zero or not finite (the frame stays as it was).
bool bump_normal(vec3 ng, vec3 dpdu, vec3 dpdv, out vec3 n) {
  vec3 c = cross_exact(dpdu, dpdv);
  float l2 = dot_exact(c, c);
  n = c / sqrt(l2);
  // Bump-spec 6.2: a squared length below FLT_MIN (zero, or subnormal, which GPUs may flush)
  // or not finite keeps the frame.
  if (!(l2 >= FLT_MIN) || isinf(l2)) return false;
  if (any(isnan(n)) || any(isinf(n)) || (n.x == 0.0 && n.y == 0.0 && n.z == 0.0)) return false;
  if (dot_exact(n, ng) < 0.0) n = -n;
  return true;
}

// bump_shading (bump-spec 6) of material m (the material after mix resolution) at sp: the
// normal map if MATFLAG_NORMALMAP, else the bump if MATFLAG_BUMP (the displacement at the hit
// is `disp`, at the shifted contexts `disp_uv`), else nothing; then, if MATFLAG_VTURB, the
// vector turbulence of bump-spec 9 on the result. True if either gave the new shading
// geometry f (bump-spec 6.4: normal, shading_frame(n', dpdu') and pair); false (f = sp's)
// otherwise. The frame is built once, from the last pair that changed the normal (bump-spec 9
// needs only the normal and pair of the step before it).
bool bump_shading(uint m, SurfacePoint sp, float disp, vec4 disp_uv, out BumpFrame f) {
  f = BumpFrame(sp.ns, sp.t1, sp.t2, sp.sdpdu, sp.sdpdv);
  if (!BUMP_ENABLED && !NORMALMAP_ENABLED && !VTURB_ENABLED) return false;
  uint mflags = material_head(m).y;
  vec3 dpdu, dpdv, n;
  bool paired = false;
  if (NORMALMAP_ENABLED && (mflags & MATFLAG_NORMALMAP) != 0u) {
    paired = normal_map(sp, uint(material_value(m, SLOT_NORMALMAP).x), dpdu, dpdv);
  } else if (bump_wanted(mflags)) {
    bump_map(sp, disp, disp_uv, dpdu, dpdv);
    paired = true;
  }
  bool changed = false;
  if (paired && bump_normal(sp.ng, dpdu, dpdv, n)) {
    f.ns = n;
    f.dpdu = dpdu;
    f.dpdv = dpdv;
    changed = true;
  }
  // Bump-spec 9, from the normal and pair above (sp's where nothing changed them); a
  // degenerate result keeps them.
  if (VTURB_ENABLED && (mflags & MATFLAG_VTURB) != 0u) {
    vec4 vt = material_value(m, SLOT_NORMALMAP);
    if (vturb_pair(f.ns, f.dpdu, f.dpdv, sp.tex.p, vt.y, vt.z, int(vt.w), dpdu, dpdv) &&
        bump_normal(sp.ng, dpdu, dpdv, n)) {
      f.ns = n;
      f.dpdu = dpdu;
      f.dpdv = dpdv;
      changed = true;
    }
  }
  if (changed) shading_frame(f.ns, f.dpdu, f.t1, f.t2);
  return changed;
}

#endif
