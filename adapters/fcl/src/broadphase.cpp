// For FCL's broadphase managers. defaultCollisionFunction: FCL's default
// callback with the drop-in collide() on each pair. BroadphaseCollector:
// pairs from a manager, grouped per shape so that all the meshes a shape
// touches are filtered as one surface (reference §6: seams between separate
// meshes are internal edges too).
#include "internal.h"

#include <fcl/broadphase/default_broadphase_callbacks.h>
#include <fcl/geometry/shape/box.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace meshcontact::fcl {

bool defaultCollisionFunction(::fcl::CollisionObjectd* o1, ::fcl::CollisionObjectd* o2, void* data) {
  auto& d = *static_cast<::fcl::DefaultCollisionData<double>*>(data);
  if (d.done) return true;
  collide(o1, o2, d.request, d.result);  // the drop-in: it records lastStatus()
  if (!lastStatus()) {
    // The pass ends here, its result incomplete: `done` marks it (a caller
    // reading only result.isCollision() must not take the rest as clear),
    // and lastStatus() says why.
    d.done = true;
    return true;
  }
  // FCL's own rule (DefaultCollisionFunction): done once a collision has
  // filled the requested contacts.
  if (!d.request.enable_cost && d.result.isCollision() && d.result.numContacts() >= d.request.num_max_contacts)
    d.done = true;
  return d.done;
}

struct BroadphaseCollector::Impl {
  ::fcl::CollisionRequestd request;
  Options options;
  Scratch scratch;

  struct Pair {
    const ::fcl::CollisionObjectd* a;  // grouped: the shape; forwarded: o1
    const ::fcl::CollisionObjectd* b;  // grouped: the mesh; forwarded: o2
    std::uint32_t seq;                 // order of arrival
    bool grouped;
  };
  std::vector<Pair> pairs;
  std::uint32_t next_seq = 0;

  // finish() scratch.
  struct Job {
    std::uint32_t first_seq;
    std::uint32_t begin, end;  // range in `pairs` (sorted) for a group; begin = end = index for a forwarded pair
    bool grouped;
  };
  std::vector<Job> jobs;
  std::vector<const ::fcl::CollisionObjectd*> group_meshes;
  std::vector<const ::fcl::CollisionGeometryd*> group_geometries;
  ::fcl::CollisionResultd forwarded;

  std::vector<ObjectContact> contacts;

  // The group's meshes, for its deep passes' second gather.
  struct Member {
    detail::MeshDesc mesh;
    Pose to_frame;                   // model frame -> the group's frame
    const TriangleMesh* compact;     // the ModelCache's hierarchy, or null
  };
  std::vector<Member> members;
  // The group being run: its shape, its frame (the first mesh's), and
  // whether its meshes differ in pose, with the scale of their weld (the
  // core's rule: |translation| + |vertex|). Members added by reach
  // (reachMeshes) update the last two.
  const ::fcl::CollisionObjectd* group_shape = nullptr;
  Pose group_frame;
  bool poses_differ = false;
  double weld_scale = 0.0;

  // setMeshManager: the manager asked for the meshes within a query's reach
  // beyond the shape's bounds, and the probe object it is asked with (a box
  // in the world frame; made on first use, then reused).
  const ::fcl::BroadPhaseCollisionManagerd* mesh_manager = nullptr;
  std::shared_ptr<::fcl::Boxd> probe_box;
  std::unique_ptr<::fcl::CollisionObjectd> probe;
  std::vector<const ::fcl::CollisionObjectd*> reached;

  // setShapeManager: the manager whose shapes are also queried when no mesh
  // was paired with them, and finish()'s lists for that pass.
  const ::fcl::BroadPhaseCollisionManagerd* shape_manager = nullptr;
  std::vector<::fcl::CollisionObjectd*> listed;                // the shape manager's objects
  std::vector<const ::fcl::CollisionObjectd*> grouped_shapes;  // sorted: the shapes paired with a mesh
  std::vector<const ::fcl::CollisionObjectd*> unpaired;

  // The group of `shape_object` and the meshes of pairs[begin, end) (none
  // for a shape no mesh was paired with: then only those mesh_manager gives).
  Status runGroup(const ::fcl::CollisionObjectd* shape_object, std::uint32_t begin, std::uint32_t end);
  // Lists in `unpaired` the shapes of shape_manager that no mesh was paired
  // with (after `jobs` are made), in the order of their bounds' lower
  // corners.
  void listUnpaired();
  Status runForwarded(const Pair& pair);
  // Appends group_meshes[j] to the members (checked as a pair with the
  // group's shape, mapped to the group's frame); `shape_in_model`: the
  // shape's pose in its model frame.
  Status addMember(std::size_t j, Pose& shape_in_model);
  // Adds to group_meshes (not yet to the members) the mesh objects of
  // mesh_manager whose bounds overlap the world box [lo, hi] and that the
  // group does not have yet, in the manager's order.
  void reachMeshes(const Vec3& lo, const Vec3& hi);
  // Appends member j's triangles in `volume` (its model frame) to `out`,
  // in the group's frame, with mesh index j and its vertex indices as keys.
  Status gatherMember(std::uint32_t j, const detail::QueryVolume& volume, std::vector<CandidateTriangle>& out);
  // The members' candidates as one surface: welded (when poses_differ, on
  // weld_scale), keyed by object.
  Status joinMembers(std::vector<CandidateTriangle>& candidates);
};

Status BroadphaseCollector::Impl::gatherMember(std::uint32_t j, const detail::QueryVolume& volume,
                                               std::vector<CandidateTriangle>& out) {
  const Member& member = members[j];
  Scratch::Impl& sc = scratch.impl();
  if (member.compact) {
    // The core's midphase on the cached hierarchy, in the model frame,
    // then mapped like the in-place walk; its keys are the vertex indices,
    // as the walk's.
    const MeshInstance instance{member.compact, Pose::identity()};
    Status s = gatherCandidates(&instance, 1, volume.lo, volume.hi, KeyMode::kVertexIndex, sc.query, sc.gathered);
    if (!s) return s;
    const bool identity = member.to_frame.isIdentity();
    for (CandidateTriangle c : sc.gathered) {
      if (!identity)
        for (Vec3& v : c.vertices) v = member.to_frame.apply(v);
      c.mesh = j;
      out.push_back(c);
    }
    return Status::ok();
  }
  return detail::gatherModel(member.mesh, volume, member.to_frame, j, sc.stack, out);
}

Status BroadphaseCollector::Impl::joinMembers(std::vector<CandidateTriangle>& candidates) {
  if (poses_differ) {
    Status s = weldCorners(candidates.data(), candidates.size(), kWeldRoundOff * weld_scale, scratch.impl().query);
    if (!s) return s;
  }
  // The objects form one surface where their vertices meet at bitwise-equal
  // positions (reference §6; after the weld above): keys that tell the
  // objects apart (object << 32 | vertex index; equal keys are then equal
  // positions), and the filter matches positions for the edge and vertex
  // contacts those keys keep (KeyMode::kVertexPosition on index keys,
  // query.h).
  for (CandidateTriangle& c : candidates)
    for (std::uint64_t& key : c.keys) key = static_cast<std::uint64_t>(c.mesh) << 32 | (key & 0xffffffffu);
  return Status::ok();
}

Status BroadphaseCollector::Impl::addMember(std::size_t j, Pose& shape_in_model) {
  const ::fcl::CollisionObjectd& mo = *group_meshes[j];
  Member member;
  detail::describeMesh(group_geometries[j], member.mesh);
  Pose mesh_pose;
  Status s =
      detail::checkPair(member.mesh, mo, *group_shape, "a mesh of the group", "shape", mesh_pose, shape_in_model);
  if (!s) return s;
  const bool same_frame = mo.getTransform().matrix() == group_meshes[0]->getTransform().matrix();
  member.to_frame = same_frame ? Pose::identity() : detail::relativePose(group_frame, mesh_pose);
  poses_differ = poses_differ || !same_frame;
  // The model's local bounds (CollisionObject's constructor computes them).
  const ::fcl::CollisionGeometryd& g = *group_geometries[j];
  weld_scale = std::max(weld_scale, member.to_frame.translation.cwiseAbs().maxCoeff() +
                                        g.aabb_center.cwiseAbs().maxCoeff() + g.aabb_radius);
  member.compact = options.cache ? options.cache->impl().find(member.mesh) : nullptr;
  members.push_back(member);
  return Status::ok();
}

void BroadphaseCollector::Impl::reachMeshes(const Vec3& lo, const Vec3& hi) {
  if (!probe) {
    probe_box = std::make_shared<::fcl::Boxd>(1.0, 1.0, 1.0);
    probe = std::make_unique<::fcl::CollisionObjectd>(probe_box);
  }
  // The box, a little wider (round-off in its centre and half extents:
  // more meshes only add triangles that each pass rejects).
  const Vec3 half = 0.5 * (hi - lo), center = 0.5 * (lo + hi);
  const Vec3 wide = half + Vec3::Constant(1e-12 * (half.maxCoeff() + center.cwiseAbs().maxCoeff()));
  probe_box->side = 2.0 * wide;
  probe_box->computeLocalAABB();
  ::fcl::Transform3d tf = ::fcl::Transform3d::Identity();
  tf.translation() = center;
  probe->setTransform(tf);
  probe->computeAABB();
  reached.clear();
  mesh_manager->collide(probe.get(), this, [](::fcl::CollisionObjectd* o1, ::fcl::CollisionObjectd* o2, void* data) {
    auto& impl = *static_cast<Impl*>(data);
    impl.reached.push_back(o1 == impl.probe.get() ? o2 : o1);
    return false;
  });
  detail::MeshDesc mesh;
  for (const ::fcl::CollisionObjectd* o : reached) {
    const ::fcl::CollisionGeometryd* g = o->collisionGeometry().get();
    if (!detail::describeMesh(g, mesh)) continue;  // a shape, or a geometry the pipeline does not read
    if (std::find(group_meshes.begin(), group_meshes.end(), o) != group_meshes.end()) continue;
    group_meshes.push_back(o);
    group_geometries.push_back(g);
  }
}

BroadphaseCollector::BroadphaseCollector(const ::fcl::CollisionRequestd& request, const Options& options)
    : impl_(std::make_unique<Impl>()) {
  impl_->request = request;
  impl_->options = options;
}

BroadphaseCollector::~BroadphaseCollector() = default;

bool BroadphaseCollector::callback(::fcl::CollisionObjectd* o1, ::fcl::CollisionObjectd* o2, void* collector) {
  Impl& impl = *static_cast<BroadphaseCollector*>(collector)->impl_;
  detail::MeshDesc mesh;
  detail::ShapeDesc shape;
  const ::fcl::CollisionGeometryd* g1 = o1 ? o1->collisionGeometry().get() : nullptr;
  const ::fcl::CollisionGeometryd* g2 = o2 ? o2->collisionGeometry().get() : nullptr;
  const std::uint32_t seq = impl.next_seq++;
  bool mesh_first = false;
  if (!impl.request.enable_cost && detail::classifyPair(g1, g2, mesh, shape, mesh_first))
    impl.pairs.push_back(mesh_first ? Impl::Pair{o2, o1, seq, true} : Impl::Pair{o1, o2, seq, true});  // (shape, mesh)
  else
    impl.pairs.push_back({o1, o2, seq, false});
  return false;  // the grouped queries need every pair first
}

Status BroadphaseCollector::Impl::runForwarded(const Pair& pair) {
  forwarded.clear();
  Report report;
  Status s = collide(pair.a, pair.b, request, forwarded, options, scratch, &report);
  if (!s) return s;
  for (std::size_t i = 0; i < forwarded.numContacts(); ++i)
    contacts.push_back({pair.a, pair.b, forwarded.getContact(i)});
  return Status::ok();
}

Status BroadphaseCollector::Impl::runGroup(const ::fcl::CollisionObjectd* shape_object, std::uint32_t begin,
                                           std::uint32_t end) {
  detail::ShapeDesc shape;
  detail::describeShape(shape_object->collisionGeometry().get(), shape);
  Pose shape_pose;
  Status s = detail::poseFromTransform(shape_object->getTransform(), "shape", shape_pose);
  if (!s) return s;

  group_meshes.clear();
  group_geometries.clear();
  for (std::uint32_t i = begin; i < end; ++i) {
    const ::fcl::CollisionObjectd* m = pairs[i].b;
    if (std::find(group_meshes.begin(), group_meshes.end(), m) != group_meshes.end()) continue;
    group_meshes.push_back(m);
    group_geometries.push_back(m->collisionGeometry().get());
  }
  group_shape = shape_object;
  const double cd = options.settings.contact_distance;
  if (mesh_manager != nullptr && cd > 0.0) {
    // The meshes within the contact distance: the manager paired those whose
    // bounds overlap the shape's, not those within `cd` of them.
    const ::fcl::AABBd& box = shape_object->getAABB();
    reachMeshes(box.min_ - Vec3::Constant(cd), box.max_ + Vec3::Constant(cd));
  }
  if (group_meshes.empty()) return Status::ok();  // an unpaired shape with no mesh within reach
  // Collision checking (a boolean request wanting one contact, as collide()
  // defines it): whether the shape touches any of its meshes, the OR of the
  // pairs' answers, which seams do not change. Each pair gets collide()'s
  // own check, which stops at its first triangle in contact, and the first
  // pair in collision gives the group's contact; the grouped query would
  // build every contact of every mesh only to keep one. Every pair's model
  // and transforms are checked first (checkPair): such an error is reported
  // (and the group gets no contact), not skipped because an earlier mesh was
  // hit. What only a walk finds (a triangle indexing past the vertices) is
  // found, as in one collide() check, where the walk reaches it.
  if (!request.enable_contact && request.num_max_contacts == 1 && options.settings.trace == nullptr) {
    for (const ::fcl::CollisionObjectd* m : group_meshes) {
      detail::MeshDesc mesh;
      detail::describeMesh(m->collisionGeometry().get(), mesh);
      Pose mesh_pose, shape_in_model;
      s = detail::checkPair(mesh, *m, *shape_object, "a mesh of the group", "shape", mesh_pose, shape_in_model);
      if (!s) return s;
    }
    for (const ::fcl::CollisionObjectd* m : group_meshes) {
      forwarded.clear();
      s = collide(m, shape_object, request, forwarded, options, scratch);
      if (!s) return s;
      if (forwarded.numContacts() > 0) {
        contacts.push_back({m, shape_object, forwarded.getContact(0)});
        break;
      }
    }
    return Status::ok();
  }

  // The query frame is the first mesh's frame: a single mesh gives exactly
  // collide()'s result, and meshes with bitwise-equal transforms keep
  // bitwise-equal shared vertices (their seams are then recognized).
  s = detail::poseFromTransform(group_meshes[0]->getTransform(), "mesh 0 of the group", group_frame);
  if (!s) return s;
  const Pose shape_in_frame = detail::relativePose(group_frame, shape_pose);

  Scratch::Impl& sc = scratch.impl();
  sc.candidates.clear();
  poses_differ = false;
  weld_scale = 0.0;
  members.clear();
  for (std::size_t j = 0; j < group_meshes.size(); ++j) {
    Pose shape_in_model;
    s = addMember(j, shape_in_model);
    if (!s) return s;
    s = gatherMember(static_cast<std::uint32_t>(j),
                     detail::makeQueryVolume(shape, shape_in_model, options.settings.contact_distance), sc.candidates);
    if (!s) return s;
  }
  s = joinMembers(sc.candidates);
  if (!s) return s;
  QuerySettings settings = options.settings;
  settings.key_mode = KeyMode::kVertexPosition;
  // A support shape's deep passes gather their own, wider candidates
  // (convex.h, CandidateSource): every member on their box (group frame),
  // joined as above. With a mesh manager (setMeshManager), the meshes on
  // that box the manager did not pair with the shape join the members
  // first; otherwise only the members are asked.
  struct Members final : CandidateSource {
    Impl& impl;
    explicit Members(Impl& i) : impl(i) {}
    Status gather(const Vec3& lo, const Vec3& hi, std::vector<CandidateTriangle>& out) override {
      out.clear();
      const Vec3 center = 0.5 * (lo + hi), half = 0.5 * (hi - lo);
      if (impl.mesh_manager != nullptr) {
        const Pose& frame = impl.group_frame;
        const Vec3 world_center = frame.apply(center), world_half = frame.rotation.cwiseAbs() * half;
        impl.reachMeshes(world_center - world_half, world_center + world_half);
        for (std::size_t j = impl.members.size(); j < impl.group_meshes.size(); ++j) {
          Pose shape_in_model;
          Status s = impl.addMember(j, shape_in_model);
          if (!s) return s;
        }
      }
      for (std::size_t j = 0; j < impl.members.size(); ++j) {
        // The box's bounds in the member's model frame.
        const Pose& to_frame = impl.members[j].to_frame;
        const Vec3 c = to_frame.applyInverse(center);
        const Vec3 h = to_frame.rotation.transpose().cwiseAbs() * half;
        Status s = impl.gatherMember(static_cast<std::uint32_t>(j), detail::boxQueryVolume(c - h, c + h), out);
        if (!s) return s;
      }
      return impl.joinMembers(out);
    }
  } deeper(*this);
  s = detail::collideCandidates(shape, shape_in_frame, sc.candidates.data(), sc.candidates.size(), settings, sc.query,
                                sc.contacts, CandidateCoverage::kComplete, &deeper);
  if (!s) return s;
  if (sc.contacts.empty() && !sc.candidates.empty()) {
    Contact through;
    if (detail::throughContact(shape, shape_in_frame, sc.candidates.data(), sc.candidates.size(), &request, through))
      sc.contacts.push_back(through);
  }
  detail::convertContacts(sc.contacts, group_frame, true, group_geometries.data(), shape.geometry,
                          request.num_max_contacts, sc.order, sc.out);
  // out[k] is sc.contacts[sc.order[k]] (convertContacts): its mesh index
  // names the object (several objects may share one geometry).
  for (std::size_t k = 0; k < sc.out.size(); ++k)
    contacts.push_back({group_meshes[sc.contacts[sc.order[k]].mesh], shape_object, sc.out[k]});
  return Status::ok();
}

Status BroadphaseCollector::finish() {
  Impl& impl = *impl_;
  impl.contacts.clear();
  if (impl.request.num_max_contacts == 0)
    return {ErrorCode::kInvalidSettings, "request.num_max_contacts is 0 (no contact could be returned)"};
  const double cd = impl.options.settings.contact_distance;
  if (!std::isfinite(cd) || cd < 0.0)
    return {ErrorCode::kInvalidSettings, "contact_distance must be finite and >= 0, got " + detail::describeValue(cd)};
  // Group the mesh-vs-shape pairs by shape, each group in arrival order (a
  // total order: seq is unique; std::sort, as std::stable_sort takes a
  // buffer from the heap on every call).
  std::vector<Impl::Pair>& pairs = impl.pairs;
  std::sort(pairs.begin(), pairs.end(), [](const Impl::Pair& x, const Impl::Pair& y) {
    if (x.grouped != y.grouped) return x.grouped;
    if (x.grouped && x.a != y.a) return std::less<const ::fcl::CollisionObjectd*>()(x.a, y.a);
    return x.seq < y.seq;
  });
  impl.jobs.clear();
  for (std::uint32_t i = 0; i < pairs.size();) {
    std::uint32_t end = i + 1;
    if (pairs[i].grouped)
      while (end < pairs.size() && pairs[end].grouped && pairs[end].a == pairs[i].a) ++end;
    impl.jobs.push_back({pairs[i].seq, i, end, pairs[i].grouped});
    i = end;
  }
  // Shapes in the order the manager first reported them (not by address).
  std::sort(impl.jobs.begin(), impl.jobs.end(),
            [](const Impl::Job& x, const Impl::Job& y) { return x.first_seq < y.first_seq; });
  Status first_error;
  const auto keepFirst = [&first_error](Status s) {
    if (!s && first_error.isOk()) first_error = std::move(s);
  };
  for (const Impl::Job& job : impl.jobs)
    keepFirst(job.grouped ? impl.runGroup(pairs[job.begin].a, job.begin, job.end)
                          : impl.runForwarded(pairs[job.begin]));
  if (impl.shape_manager != nullptr && impl.mesh_manager != nullptr && cd > 0.0 && !impl.request.enable_cost) {
    impl.listUnpaired();
    for (const ::fcl::CollisionObjectd* o : impl.unpaired) keepFirst(impl.runGroup(o, 0, 0));
  }
  return first_error;
}

void BroadphaseCollector::Impl::listUnpaired() {
  grouped_shapes.clear();
  for (const Job& job : jobs)
    if (job.grouped) grouped_shapes.push_back(pairs[job.begin].a);
  std::sort(grouped_shapes.begin(), grouped_shapes.end(), std::less<const ::fcl::CollisionObjectd*>());
  listed.clear();
  shape_manager->getObjects(listed);
  unpaired.clear();
  for (const ::fcl::CollisionObjectd* o : listed) {
    detail::ShapeDesc shape;
    if (!detail::describeShape(o->collisionGeometry().get(), shape)) continue;  // a mesh, or not a shape we query
    if (std::binary_search(grouped_shapes.begin(), grouped_shapes.end(), o,
                           std::less<const ::fcl::CollisionObjectd*>()))
      continue;
    unpaired.push_back(o);
  }
  // FCL's managers list their objects in the order of a hash of their
  // addresses, which changes from run to run: ordered by where they are
  // instead (the address breaks only exact ties). Bounds with a NaN (a NaN
  // transform: runGroup reports it) go last, so that the order stays a
  // strict weak one.
  std::sort(unpaired.begin(), unpaired.end(), [](const ::fcl::CollisionObjectd* x, const ::fcl::CollisionObjectd* y) {
    const Vec3& a = x->getAABB().min_;
    const Vec3& b = y->getAABB().min_;
    for (int k = 0; k < 3; ++k) {
      const bool a_nan = std::isnan(a[k]), b_nan = std::isnan(b[k]);
      if (a_nan != b_nan) return b_nan;
      if (!a_nan && a[k] != b[k]) return a[k] < b[k];
    }
    return std::less<const ::fcl::CollisionObjectd*>()(x, y);
  });
}

Status BroadphaseCollector::finish(::fcl::CollisionResultd& result) {
  Status s = finish();
  for (const ObjectContact& c : impl_->contacts) result.addContact(c.contact);
  return s;
}

void BroadphaseCollector::setMeshManager(const ::fcl::BroadPhaseCollisionManagerd* meshes) {
  impl_->mesh_manager = meshes;
}

void BroadphaseCollector::setShapeManager(const ::fcl::BroadPhaseCollisionManagerd* shapes) {
  impl_->shape_manager = shapes;
}

const std::vector<ObjectContact>& BroadphaseCollector::contacts() const { return impl_->contacts; }

void BroadphaseCollector::clear() {
  impl_->pairs.clear();
  impl_->contacts.clear();
  impl_->next_seq = 0;
}

}  // namespace meshcontact::fcl
