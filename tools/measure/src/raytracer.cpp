// Embree 3 ground truth (see raytracer.hpp).
#include "csm_measure/raytracer.hpp"

#include <embree3/rtcore.h>

#include <limits>
#include <stdexcept>
#include <string>

namespace csm_measure {

struct RayTracer::Impl {
  RTCDevice device = nullptr;
  RTCScene scene = nullptr;
  glm::dvec3 anchorWs{0.0};
};

namespace {

void check(RTCDevice device, const char* what) {
  const RTCError e = rtcGetDeviceError(device);
  if (e != RTC_ERROR_NONE) {
    throw std::runtime_error(std::string(what) + ": Embree error " + std::to_string(int(e)));
  }
}

}  // namespace

RayTracer::RayTracer(const Scene& scene) : impl_(new Impl) {
  impl_->anchorWs = scene.originWs();
  impl_->device = rtcNewDevice("threads=2");
  if (!impl_->device) {
    delete impl_;
    throw std::runtime_error("rtcNewDevice failed");
  }
  impl_->scene = rtcNewScene(impl_->device);
  rtcSetSceneBuildQuality(impl_->scene, RTC_BUILD_QUALITY_HIGH);
  for (size_t k = 0; k < scene.instances().size(); ++k) {
    const Instance& in = scene.instances()[k];
    const MeshData& m = scene.meshes()[in.mesh];
    RTCGeometry geom = rtcNewGeometry(impl_->device, RTC_GEOMETRY_TYPE_TRIANGLE);
    auto* v = static_cast<float*>(rtcSetNewGeometryBuffer(
        geom, RTC_BUFFER_TYPE_VERTEX, 0, RTC_FORMAT_FLOAT3, 3 * sizeof(float), m.vertices.size()));
    // Anchor-relative positions: the translation difference is formed in double first.
    const glm::dvec3 t = in.translationWs - impl_->anchorWs;
    for (size_t i = 0; i < m.vertices.size(); ++i) {
      const glm::dvec3 p = t + glm::dvec3(in.linearWs * m.vertices[i].position);
      v[3 * i + 0] = float(p.x);
      v[3 * i + 1] = float(p.y);
      v[3 * i + 2] = float(p.z);
    }
    auto* idx = static_cast<unsigned*>(
        rtcSetNewGeometryBuffer(geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                3 * sizeof(unsigned), m.indices.size() / 3));
    for (size_t i = 0; i < m.indices.size(); ++i) idx[i] = m.indices[i];
    rtcCommitGeometry(geom);
    rtcAttachGeometry(impl_->scene, geom);
    rtcReleaseGeometry(geom);
  }
  rtcCommitScene(impl_->scene);
  try {
    check(impl_->device, "RayTracer: building the scene");
  } catch (...) {
    rtcReleaseScene(impl_->scene);
    rtcReleaseDevice(impl_->device);
    delete impl_;
    throw;
  }
}

RayTracer::~RayTracer() {
  if (impl_->scene) rtcReleaseScene(impl_->scene);
  if (impl_->device) rtcReleaseDevice(impl_->device);
  delete impl_;
}

void RayTracer::visibility(std::span<const glm::dvec3> posWs, std::span<const glm::vec3> normalWs,
                           const glm::dvec3& lightDirWs, std::span<float> out, double liftM) const {
  const glm::dvec3 toLight = -glm::normalize(lightDirWs);
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  for (size_t i = 0; i < posWs.size(); ++i) {
    const glm::dvec3 n(normalWs[i]);
    const glm::dvec3 o = posWs[i] - impl_->anchorWs + liftM * (n + toLight);
    RTCRay ray{};
    ray.org_x = float(o.x);
    ray.org_y = float(o.y);
    ray.org_z = float(o.z);
    ray.dir_x = float(toLight.x);
    ray.dir_y = float(toLight.y);
    ray.dir_z = float(toLight.z);
    ray.tnear = 0.0f;
    ray.tfar = std::numeric_limits<float>::infinity();
    ray.mask = 0xFFFFFFFFu;
    ray.flags = 0;
    rtcOccluded1(impl_->scene, &context, &ray);
    // Embree sets tfar to -inf when the ray is occluded.
    out[i] = ray.tfar < 0.0f ? 0.0f : 1.0f;
  }
}

bool RayTracer::intersect(const glm::dvec3& originWs, const glm::dvec3& dirWs, glm::dvec3* hitWs,
                          glm::vec3* normalWs) const {
  RTCIntersectContext context;
  rtcInitIntersectContext(&context);
  const glm::dvec3 o = originWs - impl_->anchorWs;
  RTCRayHit rh{};
  rh.ray.org_x = float(o.x);
  rh.ray.org_y = float(o.y);
  rh.ray.org_z = float(o.z);
  rh.ray.dir_x = float(dirWs.x);
  rh.ray.dir_y = float(dirWs.y);
  rh.ray.dir_z = float(dirWs.z);
  rh.ray.tnear = 0.0f;
  rh.ray.tfar = std::numeric_limits<float>::infinity();
  rh.ray.mask = 0xFFFFFFFFu;
  rh.hit.geomID = RTC_INVALID_GEOMETRY_ID;
  rtcIntersect1(impl_->scene, &context, &rh);
  if (rh.hit.geomID == RTC_INVALID_GEOMETRY_ID) return false;
  if (hitWs) *hitWs = originWs + double(rh.ray.tfar) * dirWs;
  if (normalWs) *normalWs = glm::normalize(glm::vec3(rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z));
  return true;
}

}  // namespace csm_measure
