// The convex path against the box path (SAT) on the same box: a box-shaped
// ConvexHull through collideConvex and the same Box through collideBox, on
// seeded random poses over each scene, reported per scene as a Markdown
// table. Past the margin the convex path works from a shrunk core (convex.h,
// deep penetration), the box path from the box's own axes: where they
// disagree, this counts it.
//   build/benchmarks/convex_sat_agreement [placements per scene, default 20000]
// Columns, over the poses where SAT's deepest contact is under 0.08 (less
// than the box's half height: touching or sunk, not buried) and either path
// has a contact:
//   - stray: poses with a convex contact deeper than 1e-3 whose normal is
//     more than 10 degrees from every SAT normal;
//   - lost: poses with a SAT normal (contact deeper than 4e-3: the hull's
//     rounded corners sit up to (sqrt(3) - 1) x margin = 3.7e-3 higher than
//     the box's) that no convex contact is within 10 degrees of.
// SAT is not an oracle: its triangles are one-sided as the convex path's
// are, and at a concave corner or under a curved surface either may be the
// one that is right. On flat floors both must agree (0 and 0).
#include <meshcontact/meshcontact.h>
#include <meshcontact_scenes/scenes.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

namespace mc = meshcontact;

namespace {

struct Counts {
  int compared = 0;
  int deep = 0;  // SAT's deepest contact past 1.5 x the hull's margin
  int stray = 0;
  int lost = 0;
};

bool near(const mc::Vec3& normal, const std::vector<mc::Contact>& others, double cos_limit) {
  for (const mc::Contact& o : others)
    if (normal.dot(o.normal) > cos_limit) return true;
  return false;
}

Counts compare(const mc::scenes::SceneMesh& scene, int placements, std::uint64_t seed) {
  mc::TriangleMesh mesh;
  if (!mesh.build(scene.view()).isOk()) std::exit(2);
  const mc::Vec3 h(0.3, 0.2, 0.1);
  mc::ConvexHull hull;
  if (!hull.build(mc::scenes::boxCorners(h)).isOk()) std::exit(2);
  mc::QuerySettings settings;
  settings.reduce_manifold = false;  // every patch's points
  mc::QueryScratch scratch;
  std::vector<mc::Contact> convex, sat;
  const mc::Vec3 lo = mesh.boundsLo(), hi = mesh.boundsHi();
  const double cos10 = std::cos(10.0 * M_PI / 180.0);
  mc::scenes::Rng rng(seed);
  Counts n;
  for (int i = 0; i < placements; ++i) {
    mc::Pose pose;
    // Half the poses turned about z only (lying flat), half at random.
    pose.rotation = i % 2 ? rng.rotation() : mc::Mat3(Eigen::AngleAxisd(rng.uniform(0.0, M_PI), mc::Vec3::UnitZ()));
    pose.translation = mc::Vec3(rng.uniform(lo.x() + 0.3, hi.x() - 0.3), rng.uniform(lo.y() + 0.3, hi.y() - 0.3),
                                rng.uniform(lo.z(), hi.z() + 0.3));
    if (!mc::collideConvex(mesh, hull, pose, settings, scratch, convex).isOk()) std::exit(3);
    if (!mc::collideBox(mesh, mc::Box{h}, pose, settings, scratch, sat).isOk()) std::exit(3);
    if (convex.empty() && sat.empty()) continue;
    double sat_depth = 0.0;
    for (const mc::Contact& c : sat) sat_depth = std::max(sat_depth, c.depth);
    if (sat_depth >= 0.08) continue;
    ++n.compared;
    n.deep += sat_depth > 1.5 * hull.margin();
    bool stray = false, lost = false;
    for (const mc::Contact& c : convex) stray = stray || (c.depth > 1e-3 && !near(c.normal, sat, cos10));
    for (const mc::Contact& c : sat) lost = lost || (c.depth > 4e-3 && !near(c.normal, convex, cos10));
    n.stray += stray;
    n.lost += lost;
  }
  return n;
}

}  // namespace

int main(int argc, char** argv) {
  const int placements = argc > 1 ? std::atoi(argv[1]) : 20000;
  if (placements <= 0) {
    std::fprintf(stderr, "usage: %s [placements per scene > 0]\n", argv[0]);
    return 1;
  }
  struct Named {
    const char* name;
    mc::scenes::SceneMesh mesh;
  };
  const Named scenes[] = {
      {"step (1 m cliff)", mc::scenes::step(2.0, 1.0, 0.5, 23)},
      {"ridge (30 deg)", mc::scenes::ridge(2.0, 30.0, 0.5, 4)},
      {"V-groove (30 deg)", mc::scenes::vGroove(2.0, 30.0, 0.5, 3)},
      {"sine terrain", mc::scenes::sineTerrain(8, 8, 0.5, 0.4, 3.0, 22)},
      {"flat floor, 0.5 m cells", mc::scenes::flatFloor(8, 8, 0.5, 5)},
      {"flat floor, 0.1 m cells", mc::scenes::flatFloor(40, 40, 0.1, 5)},
  };
  std::printf("| scene | poses compared | SAT past 1.5 x margin | stray | lost |\n|---|---|---|---|---|\n");
  for (const Named& s : scenes) {
    const Counts n = compare(s.mesh, placements, 7);
    std::printf("| %s | %d | %d | %d | %d |\n", s.name, n.compared, n.deep, n.stray, n.lost);
  }
  return 0;
}
