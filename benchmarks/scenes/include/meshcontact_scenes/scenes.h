#pragma once
// The scene library shared by tests, benchmarks and examples: procedural,
// seeded, deterministic meshes (the same seed gives bitwise the same mesh on
// every machine: the generator is splitmix64, not <random>'s distributions).

#include <meshcontact/geometry.h>
#include <meshcontact/mesh.h>

#include <cstdint>
#include <string>
#include <vector>

namespace meshcontact::scenes {

/// Vertices (x, y, z per vertex) and triangles (3 indices each), CCW front.
struct SceneMesh {
  std::vector<double> vertices;
  std::vector<std::uint32_t> indices;

  std::size_t vertexCount() const { return vertices.size() / 3; }
  std::size_t triangleCount() const { return indices.size() / 3; }
  Vec3 vertex(std::size_t i) const { return Vec3(vertices[3 * i], vertices[3 * i + 1], vertices[3 * i + 2]); }
  MeshView view() const { return {vertices.data(), vertexCount(), indices.data(), triangleCount()}; }
  std::uint32_t addVertex(const Vec3& p);
  void addTriangle(std::uint32_t a, std::uint32_t b, std::uint32_t c);
  /// Appends another mesh (indices shifted).
  void append(const SceneMesh& other);
};

/// Deterministic pseudo-random numbers (splitmix64).
class Rng {
 public:
  explicit Rng(std::uint64_t seed) : state_(seed) {}
  std::uint64_t next();
  double uniform();                      // [0, 1)
  double uniform(double lo, double hi);  // [lo, hi)
  /// A point of the box [lo, hi): uniform(lo.x(), hi.x()), then y, then z, drawn
  /// in that order. Use it rather than Vec3(uniform(..), uniform(..), uniform(..)):
  /// the order in which a call's or a constructor's parenthesised arguments are
  /// evaluated is unspecified (GCC goes right to left, Clang left to right), so
  /// the same seed would give different points in a GCC and a Clang build. (A
  /// braced list, Vec3{...}, is evaluated left to right; so are separate
  /// statements.)
  Vec3 uniformVector(const Vec3& lo, const Vec3& hi);
  Vec3 unitVector();
  /// A uniformly random rotation (quaternion from three uniforms, Shoemake).
  Mat3 rotation();

 private:
  std::uint64_t state_;
};

/// The shortest rotation taking direction `from` to direction `to` (neither
/// need be unit). It is Eigen's Quaternion::FromTwoVectors, compiled once here:
/// that template instantiates a JacobiSVD (for opposite directions), which
/// made each test file calling it compile 10-25 s longer under clang's
/// sanitizers.
Mat3 rotationBetween(const Vec3& from, const Vec3& to);

/// A planar patch: origin + s * u + t * v for s, t in [0, 1], split in
/// nu x nv cells, each cut along a random diagonal. Interior vertices are
/// moved in the plane by up to `jitter` of a cell along each direction
/// (boundary vertices stay put, so neighbouring patches meet at bitwise-equal
/// positions). jitter < 0.25 keeps every triangle unfolded (two vertices of a
/// cell cannot cross the diagonal between them); larger values are rejected.
/// The front face is along u x v.
void addGridPatch(SceneMesh& mesh, const Vec3& origin, const Vec3& u, const Vec3& v, int nu, int nv, Rng& rng,
                  double jitter);

/// Merges vertices with bitwise-equal positions (-0 == +0); keeps triangles.
SceneMesh weld(const SceneMesh& mesh);
/// Gives every triangle its own three vertices (like an STL file).
SceneMesh unweld(const SceneMesh& mesh);

/// Flat floor z = 0 over [0, nx*cell] x [0, ny*cell], random diagonals, in-plane jitter.
SceneMesh flatFloor(int nx, int ny, double cell, std::uint64_t seed, double jitter = 0.2);

/// A bumpy terrain over the same grid as flatFloor: z = amplitude *
/// sin(2 pi x / wavelength) * sin(2 pi y / wavelength) at every vertex (after
/// the in-plane jitter). Welded; no two triangles are coplanar in general, so
/// it exercises edge and vertex contacts as well as faces.
SceneMesh sineTerrain(int nx, int ny, double cell, double amplitude, double wavelength, std::uint64_t seed,
                      double jitter = 0.25);

/// The same floor as separate tile meshes of `cells_per_tile`^2 cells each;
/// neighbouring tiles duplicate their shared vertices (bitwise equal).
std::vector<SceneMesh> tiledFloor(int tiles_x, int tiles_y, int cells_per_tile, double cell, std::uint64_t seed,
                                  double jitter = 0.2);

/// A step (cliff): floor z = height for x < 0, a wall facing +x at x = 0, floor
/// z = 0 for x > 0; each part `half_extent` wide in x and 2*half_extent in y.
SceneMesh step(double half_extent, double height, double cell, std::uint64_t seed);
/// A concave V-groove along y: two slopes at `slope_deg` from horizontal meeting at x = 0, z = 0.
SceneMesh vGroove(double half_extent, double slope_deg, double cell, std::uint64_t seed);
/// A convex ridge along y (the V-groove upside down), apex at x = 0, z = 0.
SceneMesh ridge(double half_extent, double slope_deg, double cell, std::uint64_t seed);

/// A bowl, concave up: the paraboloid z = depth * (x^2 + y^2) / half_extent^2
/// over the square [-half_extent, half_extent]^2, tessellated like flatFloor
/// (cells of about `cell`, seeded random diagonals, in-plane jitter applied
/// before the height, so every vertex lies exactly on the paraboloid). Front
/// faces point up, toward the inside of the bowl. Welded. Lifting points onto
/// this paraboloid maps the Delaunay triangulation to the lower convex hull, so
/// an edge is concave (a valley) where the diagonal is the Delaunay one and
/// slightly convex (a ridge) where the random diagonal is the other: both
/// kinds of internal edge occur.
SceneMesh bowl(double half_extent, double depth, double cell, std::uint64_t seed, double jitter = 0.2);

/// A closed box [-half, half], centred on the origin, front faces outward:
/// each face a grid patch (addGridPatch, jitter 0.2) of cells of about
/// `cell`. Welded, so its edges and corners are shared vertices.
SceneMesh tessellatedBox(const Vec3& half, double cell, std::uint64_t seed);

/// The 8 corners of the box [-half, half] (corner i: +x when bit 0 is set,
/// +y bit 1, +z bit 2): a box-shaped ConvexHull's points.
std::vector<Vec3> boxCorners(const Vec3& half);

/// The terrain used for scaling measurements: sineTerrain with square cells of
/// kTerrainCell, amplitude kTerrainAmplitude and wavelength kTerrainWavelength
/// (max slope ~21 degrees), n x n cells with n = round(sqrt(triangles / 2)),
/// so about `triangles` triangles (2 n^2). Its analytic height is terrainHeight().
inline constexpr double kTerrainCell = 0.5;
inline constexpr double kTerrainAmplitude = 0.5;
inline constexpr double kTerrainWavelength = 8.0;
SceneMesh terrainWithTriangles(std::size_t triangles, std::uint64_t seed);
/// The analytic surface the terrain's vertices lie on (between vertices the
/// triangles differ from it by less than ~1% of the cell for these parameters).
double terrainHeight(double x, double y);
/// The 1M-triangle terrain: terrainWithTriangles(1000000) = 707 x 707 cells,
/// 999,698 triangles, 353.5 m x 353.5 m.
SceneMesh terrain1M(std::uint64_t seed);

/// A named scene: one or several pieces that form one surface.
struct Scene {
  std::string name;
  std::vector<SceneMesh> pieces;
  Vec3 lo, hi;  // box in which query shapes are placed
};

/// The accuracy scenes of DESIGN.md §5, each with a placement box around its
/// interesting part: "flat", "step", "vgroove", "ridge", "tiles".
std::vector<Scene> accuracyScenes(std::uint64_t seed);

}  // namespace meshcontact::scenes
