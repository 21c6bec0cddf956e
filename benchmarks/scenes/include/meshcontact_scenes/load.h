#pragma once
// Loading real meshes (OBJ, STL, PLY and the other formats Open Asset Import
// Library reads) into a SceneMesh. A separate target, meshcontact::scenes_io,
// so that users of the procedural scenes do not link assimp.
//
// Conventions
// - Every mesh of the file is put in the file's root frame (node transforms
//   applied) and appended into one SceneMesh, in the file's order.
// - Polygons are triangulated (fans, winding kept: front = counter-clockwise
//   as in the file). Points and lines are skipped and counted.
// - Vertices: STL stores three vertices per facet; they reach the SceneMesh
//   duplicated, exactly as in the file (assimp's JoinIdenticalVertices is NOT
//   run for STL), so a TriangleMesh built from it reports
//   hasDuplicateVertices() and KeyMode::kAuto picks position keys. For every
//   other format JoinIdenticalVertices is run: assimp's OBJ reader splits
//   vertices per face corner, and joining restores the file's sharing (a
//   vertex whose corners carry different normals or texture coordinates may
//   stay split: position keys handle that too).
// - Robustness: assimp's ValidateDataStructure step runs on every import, so
//   a corrupt file (e.g. faces indexing missing vertices) is an error, not
//   garbage; and a PLY header without "end_header" is refused before assimp
//   5.2 reads it (its reader loops forever on one).
// - Precision: Debian's assimp stores coordinates in float; they are
//   widened to double exactly, so equal positions in the file stay bitwise
//   equal.

#include "meshcontact_scenes/scenes.h"

#include <cstddef>
#include <string>
#include <utility>

namespace meshcontact::scenes {

enum class LoadError : unsigned char {
  kOk = 0,
  kFileNotFound,  // the path does not name a readable regular file
  kParseError,    // assimp could not read it (unknown format, corrupt or truncated data)
  kNoTriangles,   // read, but holds no triangle (only points/lines, or empty)
  kNonFinite,     // a vertex coordinate is NaN or infinite
  kTooLarge,      // more vertices than 32-bit indices address
};
const char* toString(LoadError error);

/// Like meshcontact::Status: ok, or a code and a message naming the file and
/// what was wrong (assimp's own message for kParseError).
class [[nodiscard]] LoadStatus {
 public:
  LoadStatus() = default;
  LoadStatus(LoadError code, std::string message) : code_(code), message_(std::move(message)) {}
  bool isOk() const { return code_ == LoadError::kOk; }
  explicit operator bool() const { return isOk(); }
  LoadError code() const { return code_; }
  const std::string& message() const { return message_; }

 private:
  LoadError code_ = LoadError::kOk;
  std::string message_;
};

struct LoadInfo {
  std::size_t meshes = 0;            // meshes in the file (after assimp's pre-transform)
  std::size_t skipped_primitives = 0;  // points and lines left out
};

/// Reads `path` (format from the extension and contents) into `out`
/// (replaced; left empty on error). `info`, when non-null, receives counts.
LoadStatus loadMesh(const std::string& path, SceneMesh& out, LoadInfo* info = nullptr);

}  // namespace meshcontact::scenes
