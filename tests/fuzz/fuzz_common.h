#pragma once
// Shared by the libFuzzer targets: turning fuzz bytes into meshes, shapes and
// poses (with NaN/Inf, huge and tiny scales, degenerate and duplicated
// triangles), and the invariants every query result must satisfy.
#include <meshcontact/meshcontact.h>

#include <fuzzer/FuzzedDataProvider.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <vector>

namespace meshcontact::fuzz {

[[noreturn]] inline void fail(const char* what) {
  std::fprintf(stderr, "fuzz invariant violated: %s\n", what);
  std::abort();
}
#define MC_FUZZ_CHECK(cond) \
  do {                      \
    if (!(cond)) ::meshcontact::fuzz::fail(#cond); \
  } while (0)

/// A coordinate-like value: mostly ordinary, sometimes extreme or non-finite.
inline double value(FuzzedDataProvider& in, double scale) {
  switch (in.ConsumeIntegralInRange<int>(0, 7)) {
    case 0: {  // raw bits: anything, NaN and Inf included
      const auto bits = in.ConsumeIntegral<std::uint64_t>();
      double x;
      std::memcpy(&x, &bits, sizeof x);
      return x;
    }
    case 1: return in.ConsumeFloatingPointInRange<double>(-1e9, 1e9);
    case 2: return in.ConsumeFloatingPointInRange<double>(-1e-9, 1e-9);
    case 3: return static_cast<double>(in.ConsumeIntegralInRange<int>(-4, 4)) * scale;  // coincident / aligned
    default: return in.ConsumeFloatingPointInRange<double>(-2.0, 2.0) * scale;
  }
}

inline Vec3 vec(FuzzedDataProvider& in, double scale) {
  const double x = value(in, scale), y = value(in, scale);
  return Vec3(x, y, value(in, scale));
}

/// Vertices and triangles; indices are sometimes out of range.
struct RawMesh {
  std::vector<double> vertices;
  std::vector<std::uint32_t> indices;
};

inline RawMesh rawMesh(FuzzedDataProvider& in) {
  RawMesh m;
  const double scale = std::ldexp(1.0, in.ConsumeIntegralInRange<int>(-30, 30));
  const int vertex_count = in.ConsumeIntegralInRange<int>(0, 24);
  for (int i = 0; i < vertex_count; ++i) {
    const Vec3 v = vec(in, scale);
    m.vertices.insert(m.vertices.end(), {v.x(), v.y(), v.z()});
  }
  const int triangle_count = in.ConsumeIntegralInRange<int>(0, 40);
  for (int t = 0; t < 3 * triangle_count; ++t)
    m.indices.push_back(in.ConsumeIntegralInRange<std::uint32_t>(0, static_cast<std::uint32_t>(vertex_count) + 1));
  return m;
}

/// One to three fuzzed meshes (`meshes` holds them; it must outlive the
/// result), as instances at the identity: those whose build fails are left
/// out (construction is fuzz target (a)). Empty when none builds.
inline std::vector<MeshInstance> buildPieces(FuzzedDataProvider& in, std::vector<TriangleMesh>& meshes) {
  const int piece_count = in.ConsumeIntegralInRange<int>(1, 3);
  meshes = std::vector<TriangleMesh>(static_cast<std::size_t>(piece_count));
  std::vector<MeshInstance> instances;
  for (TriangleMesh& mesh : meshes) {
    const RawMesh raw = rawMesh(in);
    if (!mesh.build(raw.vertices, raw.indices)) continue;
    instances.push_back({&mesh, Pose::identity()});
  }
  return instances;
}

inline Pose pose(FuzzedDataProvider& in, double scale) {
  Pose p;
  const auto quaternion = [&in] {
    Eigen::Quaterniond q(value(in, 1.0), value(in, 1.0), value(in, 1.0), value(in, 1.0));
    if (q.norm() > 1e-6 && std::isfinite(q.norm())) q.normalize();
    return q.toRotationMatrix();
  };
  switch (in.ConsumeIntegralInRange<int>(0, 4)) {
    case 0: return p;  // identity
    case 1:            // a rotation from a (normalized) quaternion
      p.rotation = quaternion();
      break;
    case 2: {  // a rotation off by 1e-16..1e-6 per entry: either side of the 1e-9 orthonormality bound
      p.rotation = quaternion();
      const double off = std::ldexp(1.0, -in.ConsumeIntegralInRange<int>(20, 53));
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) p.rotation(r, c) += off * in.ConsumeFloatingPointInRange<double>(-1.0, 1.0);
      break;
    }
    default:  // arbitrary entries: mostly invalid rotations
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 3; ++c) p.rotation(r, c) = value(in, 1.0);
  }
  p.translation = vec(in, scale);
  return p;
}

/// Every contact finite, unit normal, within the queried meshes.
inline void checkContacts(const std::vector<Contact>& contacts, const MeshInstance* instances, std::size_t count) {
  for (const Contact& c : contacts) {
    MC_FUZZ_CHECK(c.point.allFinite());
    MC_FUZZ_CHECK(c.normal.allFinite());
    MC_FUZZ_CHECK(std::isfinite(c.depth));
    MC_FUZZ_CHECK(std::abs(c.normal.norm() - 1.0) < 1e-9);
    MC_FUZZ_CHECK(c.mesh < count);
    MC_FUZZ_CHECK(c.triangle < instances[c.mesh].mesh->triangleCount());
    MC_FUZZ_CHECK(c.feature.index < 3);
  }
}

inline void checkError(const Status& s, const std::vector<Contact>& contacts) {
  MC_FUZZ_CHECK(!s.message().empty());
  MC_FUZZ_CHECK(contacts.empty());
}

}  // namespace meshcontact::fuzz
