// Fuzz target (b): shape-vs-mesh queries with arbitrary shapes, poses and
// contact distances (NaN/Inf, 1e9 and 1e-9 scales), on fuzzed meshes (with
// degenerate and duplicated triangles) queried alone or as several pieces.
#include "fuzz_common.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace meshcontact;
  FuzzedDataProvider in(data, size);
  std::vector<TriangleMesh> meshes;
  std::vector<MeshInstance> instances = fuzz::buildPieces(in, meshes);
  if (instances.empty()) return 0;
  const double scale = std::ldexp(1.0, in.ConsumeIntegralInRange<int>(-30, 30));
  for (MeshInstance& instance : instances) instance.pose = fuzz::pose(in, scale);

  QueryScratch scratch;
  std::vector<Contact> contacts;
  std::vector<TraceEntry> trace;
  for (int query = 0; query < 4 && in.remaining_bytes() > 0; ++query) {
    QuerySettings settings;
    settings.contact_distance = in.ConsumeBool() ? 0.0 : fuzz::value(in, scale);
    settings.key_mode = static_cast<KeyMode>(in.ConsumeIntegralInRange<int>(0, 2));
    settings.filter = in.ConsumeBool() ? FilterMode::kVoidedFeatures : FilterMode::kNone;
    settings.trace = in.ConsumeBool() ? &trace : nullptr;
    const Sphere sphere{fuzz::vec(in, scale), fuzz::value(in, scale)};
    const Status s = collideSphere(instances.data(), instances.size(), sphere, settings, scratch, contacts);
    if (!s) {
      fuzz::checkError(s, contacts);
      continue;
    }
    fuzz::checkContacts(contacts, instances.data(), instances.size());
    if (settings.trace) {
      // One trace entry per candidate; every kept contact appears as kept.
      std::size_t kept = 0;
      for (const TraceEntry& e : trace)
        kept += e.verdict == Verdict::kFaceContact || e.verdict == Verdict::kEdgeContact ||
                e.verdict == Verdict::kVertexContact;
      MC_FUZZ_CHECK(kept == contacts.size());
    }
  }
  return 0;
}
