// Traversal rates on the 269k-triangle Igea (scenes/igea-infinite.pbrt's camera, mesh and
// floor; triangles only, so that every tracer sees the same geometry): camera rays and
// diffuse bounce rays (closest hit), and shadow rays towards the key light (any hit), each set
// traced by lavapipe (shaders/trace.comp, the trace stage: the renderer's intersect.glsl
// specialised for the scene), by the CPU reference (cpu::intersect_closest / intersect_any) and, when
// CMake finds Debian's libembree-dev, by Embree 3 (rtcIntersect1 / rtcOccluded1, single rays,
// the peer the issue names; linked into this benchmark only). CPU tracers run one thread per
// core over interleaved slices. Counters: Mrays/s, and "agree", the fraction of rays whose
// hit or miss (and distance within 1e-3 relative) matches the CPU reference's.
#include "bench/rays.h"

#include <algorithm>
#include <cfloat>
#include <chrono>
#include <cmath>
#include <functional>
#include <memory>
#include <random>
#include <thread>
#include <vector>

#include <glm/glm.hpp>

#include "cpu/intersect.h"
#include "scene/scene.h"
#include "scene/tables.h"
#include "vk/gpu_renderer.h"

#ifdef BASALT_BENCH_EMBREE
#include <embree3/rtcore.h>
#endif

namespace basalt::bench {
namespace {

constexpr int kWidth = 320, kHeight = 240, kPerPixel = 8;  // 614k camera rays
constexpr glm::vec3 kLight(0.1f, 0.12f, 0.15f);             // the scene's key light centre

/// The ray sets: closest-hit queries (camera, bounce) or any-hit ones (shadow).
enum class Set { camera, bounce, shadow };
const char* set_name(Set s) { return s == Set::camera ? "camera" : s == Set::bounce ? "bounce" : "shadow"; }

/// Igea and the floor of scenes/igea-infinite.pbrt, without its lights (triangles only).
const SceneTables& igea() {
  static const SceneTables t = build_tables(load_scene_from_string(R"(
    LookAt 0.0 0.01 0.26   0 0 0   0 1 0
    Camera "perspective" "float fov" [ 28 ]
    Film "rgb" "integer xresolution" [ 320 ] "integer yresolution" [ 240 ]
    WorldBegin
    Material "diffuse" "rgb reflectance" [ 0.75 0.72 0.68 ]
    Shape "plymesh" "string filename" [ "../../shared/models/igea.ply" ]
    Material "diffuse" "rgb reflectance" [ 0.4 0.4 0.4 ]
    Shape "trianglemesh" "integer indices" [ 0 1 2  0 2 3 ]
      "point3 P" [ -1 -0.05 -1   1 -0.05 -1   1 -0.05 1   -1 -0.05 1 ]
  )", "igea-rays.pbrt", "scenes"));
  return t;
}

/// Runs f(i) for i in [0, n) on one thread per core (interleaved slices).
void parallel_for(std::size_t n, const std::function<void(std::size_t)>& f) {
  const unsigned threads = std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> pool;
  for (unsigned k = 0; k < threads; ++k)
    pool.emplace_back([&, k] {
      for (std::size_t i = k; i < n; i += threads) f(i);
    });
  for (std::thread& t : pool) t.join();
}

/// Camera rays: kPerPixel jittered pinhole rays per pixel of the scene's camera.
std::vector<cpu::Ray> camera_rays() {
  const glm::vec3 eye(0.0f, 0.01f, 0.26f), at(0.0f), up(0.0f, 1.0f, 0.0f);
  const glm::vec3 w = glm::normalize(at - eye), u = glm::normalize(glm::cross(w, up)),
                  v = glm::cross(u, w);
  // fov applies to the shorter image axis, as in pbrt.
  const float tan_half = std::tan(glm::radians(28.0f) * 0.5f);
  const float aspect = float(kWidth) / float(kHeight);
  std::mt19937 rng(1);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  std::vector<cpu::Ray> rays;
  rays.reserve(std::size_t(kWidth) * kHeight * kPerPixel);
  for (int y = 0; y < kHeight; ++y)
    for (int x = 0; x < kWidth; ++x)
      for (int s = 0; s < kPerPixel; ++s) {
        const float sx = (2.0f * (float(x) + U(rng)) / float(kWidth) - 1.0f) * aspect * tan_half;
        const float sy = (1.0f - 2.0f * (float(y) + U(rng)) / float(kHeight)) * tan_half;
        rays.push_back({eye, glm::normalize(w + sx * u + sy * v), FLT_MAX});
      }
  return rays;
}

/// Geometric normal of a triangle hit, facing the ray's origin, and the hit point.
bool hit_frame(const SceneTables& t, const cpu::Ray& r, const cpu::Hit& h, glm::vec3& p, glm::vec3& n) {
  if (!h.valid() || (h.prim & gpu::PRIM_SPHERE_BIT)) return false;
  const gpu::Triangle& tri = t.triangles[h.prim];
  const glm::vec3 a(t.vertices[tri.v0].p_u), b(t.vertices[tri.v1].p_u), c(t.vertices[tri.v2].p_u);
  n = glm::cross(b - a, c - a);
  if (!(glm::dot(n, n) > 0.0f)) return false;
  n = glm::normalize(n);
  if (glm::dot(n, r.d) > 0.0f) n = -n;
  p = r.o + h.t * r.d;
  return true;
}

/// Bounce rays (cosine-distributed about the facing normal) or shadow rays (to the key light)
/// from the CPU's closest hits of the camera rays, origins 1e-5 off the surface (the mesh is
/// 0.1 units tall).
std::vector<cpu::Ray> secondary_rays(Set set) {
  const SceneTables& t = igea();
  const std::vector<cpu::Ray> cam = camera_rays();
  std::vector<cpu::Hit> hits(cam.size());
  parallel_for(cam.size(), [&](std::size_t i) { hits[i] = cpu::intersect_closest(t, cam[i]); });
  std::mt19937 rng(2);
  std::uniform_real_distribution<float> U(0.0f, 1.0f);
  std::vector<cpu::Ray> rays;
  for (std::size_t i = 0; i < cam.size(); ++i) {
    glm::vec3 p, n;
    if (!hit_frame(t, cam[i], hits[i], p, n)) continue;
    const glm::vec3 o = p + 1e-5f * n;
    if (set == Set::shadow) {
      rays.push_back({o, kLight - o, 1.0f - 1e-4f});
      continue;
    }
    const glm::vec3 a = std::fabs(n.x) > 0.5f ? glm::vec3(0, 1, 0) : glm::vec3(1, 0, 0);
    const glm::vec3 tx = glm::normalize(glm::cross(a, n)), ty = glm::cross(n, tx);
    const float r = std::sqrt(U(rng)), phi = 6.2831853f * U(rng);
    const glm::vec3 d = r * std::cos(phi) * tx + r * std::sin(phi) * ty +
                        std::sqrt(std::max(0.0f, 1.0f - r * r)) * n;
    rays.push_back({o, glm::normalize(d), FLT_MAX});
  }
  return rays;
}

const std::vector<cpu::Ray>& rays(Set s) {
  static std::vector<cpu::Ray> sets[3];
  auto& r = sets[int(s)];
  if (r.empty()) r = s == Set::camera ? camera_rays() : secondary_rays(s);
  return r;
}

/// One tracer's answer per ray: the hit distance, or -1 for a miss (any-hit sets: 1 or -1).
using Answers = std::vector<float>;

/// The CPU reference's answers, computed once (the "agree" counter's baseline).
const Answers& reference(Set s) {
  static Answers ref[3];
  Answers& a = ref[int(s)];
  if (a.empty()) {
    const std::vector<cpu::Ray>& rs = rays(s);
    a.resize(rs.size());
    parallel_for(rs.size(), [&](std::size_t i) {
      if (s == Set::shadow) a[i] = cpu::intersect_any(igea(), rs[i]) ? 1.0f : -1.0f;
      else {
        const cpu::Hit h = cpu::intersect_closest(igea(), rs[i]);
        a[i] = h.valid() ? h.t : -1.0f;
      }
    });
  }
  return a;
}

/// Fraction of answers that match the reference's (both miss, or distances within 1e-3).
double agreement(Set s, const Answers& a) {
  const Answers& ref = reference(s);
  std::size_t ok = 0;
  for (std::size_t i = 0; i < a.size(); ++i)
    ok += (a[i] < 0.0f && ref[i] < 0.0f) ||
          (a[i] >= 0.0f && ref[i] >= 0.0f && std::fabs(a[i] - ref[i]) <= 1e-3f * ref[i]);
  return a.empty() ? 0.0 : double(ok) / double(a.size());
}

void finish(benchmark::State& state, Set s, const Answers& a, double rays_traced) {
  state.counters["Mrays/s"] = benchmark::Counter(rays_traced * 1e-6, benchmark::Counter::kIsRate);
  state.counters["rays"] = double(rays(s).size());
  state.counters["agree"] = agreement(s, a);
}

/// The renderer of the rays/*/gpu benchmarks (released by release_rays).
std::unique_ptr<vkx::GpuRenderer>& gpu_renderer() {
  static std::unique_ptr<vkx::GpuRenderer> r;
  return r;
}

/// Seconds the trace pipeline took to compile (cold) in this process.
double& trace_compile_seconds() {
  static double s = 0.0;
  return s;
}

/// lavapipe through the trace stage (shaders/trace.comp: the renderer's traversal, specialised
/// for the scene; compiled before timing). Ray upload and hit readback are in the time, as a
/// wavefront stage would pay for its queues.
void BM_RaysGpu(benchmark::State& state, Set s, std::function<vkx::Context&()> context) {
  const std::vector<cpu::Ray>& rs = rays(s);
  std::vector<gpu::TraceRay> q(rs.size());
  for (std::size_t i = 0; i < rs.size(); ++i)
    q[i] = gpu::TraceRay{glm::vec4(rs[i].o, rs[i].tmax), glm::vec4(rs[i].d, 0.0f)};
  // One renderer for the three sets, built without a render pipeline; a first call at the
  // largest set's size compiles the trace pipeline (cold: the benchmark disables Mesa's cache).
  std::unique_ptr<vkx::GpuRenderer>& renderer = gpu_renderer();
  if (!renderer) {
    renderer = std::make_unique<vkx::GpuRenderer>(context(), igea(), igea().features,
                                                  vkx::ShaderVariant::automatic, false);
    const auto t0 = std::chrono::steady_clock::now();
    renderer->trace(std::vector<gpu::TraceRay>(rays(Set::camera).size()), false);
    trace_compile_seconds() = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  }
  Answers a(rs.size());
  for (auto _ : state) {
    const std::vector<gpu::TraceHit> hits = renderer->trace(q, s == Set::shadow);
    for (std::size_t i = 0; i < hits.size(); ++i)
      a[i] = s == Set::shadow ? (hits[i].prim != gpu::INVALID_INDEX ? 1.0f : -1.0f) : hits[i].t;
  }
  finish(state, s, a, double(rs.size()) * double(state.iterations()));
  state.counters["compile_s"] = trace_compile_seconds();
}

/// The CPU reference's traversal, one thread per core.
void BM_RaysCpu(benchmark::State& state, Set s) {
  const std::vector<cpu::Ray>& rs = rays(s);
  Answers a(rs.size());
  for (auto _ : state)
    parallel_for(rs.size(), [&](std::size_t i) {
      if (s == Set::shadow) a[i] = cpu::intersect_any(igea(), rs[i]) ? 1.0f : -1.0f;
      else {
        const cpu::Hit h = cpu::intersect_closest(igea(), rs[i]);
        a[i] = h.valid() ? h.t : -1.0f;
      }
    });
  finish(state, s, a, double(rs.size()) * double(state.iterations()));
}

#ifdef BASALT_BENCH_EMBREE
/// Embree 3: one triangle geometry of the tables' triangles, default (medium) build quality,
/// built outside the timing; single-ray queries, one thread per core.
void BM_RaysEmbree(benchmark::State& state, Set s) {
  const SceneTables& t = igea();
  const std::vector<cpu::Ray>& rs = rays(s);
  RTCDevice device = rtcNewDevice(nullptr);
  RTCScene scene = rtcNewScene(device);
  RTCGeometry g = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
  auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3,
                                                        3 * sizeof(float), t.vertices.size()));
  for (std::size_t i = 0; i < t.vertices.size(); ++i)
    for (int c = 0; c < 3; ++c) v[3 * i + c] = t.vertices[i].p_u[c];
  auto* ix = static_cast<unsigned*>(rtcSetNewGeometryBuffer(g, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                                            3 * sizeof(unsigned), t.triangles.size()));
  for (std::size_t i = 0; i < t.triangles.size(); ++i)
    ix[3 * i] = t.triangles[i].v0, ix[3 * i + 1] = t.triangles[i].v1, ix[3 * i + 2] = t.triangles[i].v2;
  rtcCommitGeometry(g);
  rtcAttachGeometry(scene, g);
  rtcReleaseGeometry(g);
  rtcCommitScene(scene);
  Answers a(rs.size());
  for (auto _ : state)
    parallel_for(rs.size(), [&](std::size_t i) {
      RTCIntersectContext ctx;
      rtcInitIntersectContext(&ctx);
      RTCRayHit rh{};
      rh.ray.org_x = rs[i].o.x, rh.ray.org_y = rs[i].o.y, rh.ray.org_z = rs[i].o.z;
      rh.ray.dir_x = rs[i].d.x, rh.ray.dir_y = rs[i].d.y, rh.ray.dir_z = rs[i].d.z;
      rh.ray.tnear = 0.0f;
      rh.ray.tfar = rs[i].tmax;
      rh.ray.mask = ~0u;
      if (s == Set::shadow) {
        rtcOccluded1(scene, &ctx, &rh.ray);
        a[i] = rh.ray.tfar < 0.0f ? 1.0f : -1.0f;  // Embree sets tfar to -inf on a hit
        return;
      }
      rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
      rtcIntersect1(scene, &ctx, &rh);
      a[i] = rh.hit.geomID != RTC_INVALID_GEOMETRY_ID ? rh.ray.tfar : -1.0f;
    });
  rtcReleaseScene(scene);
  rtcReleaseDevice(device);
  finish(state, s, a, double(rs.size()) * double(state.iterations()));
}
#endif

}  // namespace

void release_rays() { gpu_renderer().reset(); }

void register_rays(std::function<vkx::Context&()> context) {
  for (Set s : {Set::camera, Set::bounce, Set::shadow}) {
    const std::string base = std::string("rays/igea/") + set_name(s);
    benchmark::RegisterBenchmark((base + "/gpu").c_str(), BM_RaysGpu, s, context)
        ->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();
    benchmark::RegisterBenchmark((base + "/cpu").c_str(), BM_RaysCpu, s)
        ->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();
#ifdef BASALT_BENCH_EMBREE
    benchmark::RegisterBenchmark((base + "/embree").c_str(), BM_RaysEmbree, s)
        ->Unit(benchmark::kMillisecond)->Iterations(1)->UseRealTime();
#endif
  }
}

}  // namespace basalt::bench
