#include "meshcontact_scenes/load.h"

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <sys/stat.h>

namespace meshcontact::scenes {

const char* toString(LoadError error) {
  switch (error) {
    case LoadError::kOk: return "Ok";
    case LoadError::kFileNotFound: return "FileNotFound";
    case LoadError::kParseError: return "ParseError";
    case LoadError::kNoTriangles: return "NoTriangles";
    case LoadError::kNonFinite: return "NonFinite";
    case LoadError::kTooLarge: return "TooLarge";
  }
  return "Unknown";
}

namespace {
std::string lowerExtension(const std::string& path) {
  const auto dot = path.find_last_of('.');
  const auto slash = path.find_last_of('/');
  if (dot == std::string::npos || (slash != std::string::npos && dot < slash)) return {};
  std::string ext = path.substr(dot + 1);
  std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return std::tolower(c); });
  return ext;
}
}  // namespace

LoadStatus loadMesh(const std::string& path, SceneMesh& out, LoadInfo* info) {
  out = SceneMesh();
  if (info) *info = LoadInfo();
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0 || !S_ISREG(st.st_mode))
    return {LoadError::kFileNotFound, "loadMesh: '" + path + "' is not a readable file"};

  // Guard: assimp 5.2's PLY reader loops forever on a header that never
  // ends (no "end_header" line), so such a file is refused before it gets
  // there. A PLY header is short text; 64 KiB is far more than any needs.
  {
    std::ifstream in(path, std::ios::binary);
    std::string head(64 * 1024, '\0');
    in.read(&head[0], static_cast<std::streamsize>(head.size()));
    head.resize(static_cast<std::size_t>(std::max<std::streamsize>(in.gcount(), 0)));
    const bool ply = head.compare(0, 3, "ply") == 0 || lowerExtension(path) == "ply";
    if (ply && head.find("end_header") == std::string::npos)
      return {LoadError::kParseError, "loadMesh: cannot read '" + path +
                                          "': PLY header without an end_header line in its first 64 KiB"};
  }

  // Triangulate: polygons become fans. PreTransformVertices: node transforms
  // baked in (the file's root frame). No JoinIdenticalVertices for STL (see
  // load.h): its duplicated vertices must reach the mesh unchanged.
  // ValidateDataStructure: assimp checks what its readers produced (face
  // indices in range, ...) and fails the import instead of handing on a
  // corrupt file's garbage (a binary PLY whose faces index missing vertices).
  unsigned flags = aiProcess_Triangulate | aiProcess_PreTransformVertices | aiProcess_ValidateDataStructure;
  if (lowerExtension(path) != "stl") flags |= aiProcess_JoinIdenticalVertices;
  Assimp::Importer importer;
  const aiScene* scene = importer.ReadFile(path, flags);
  if (!scene || (scene->mFlags & AI_SCENE_FLAGS_INCOMPLETE))
    return {LoadError::kParseError, "loadMesh: cannot read '" + path + "': " + importer.GetErrorString()};

  std::size_t skipped = 0;
  for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
    const aiMesh* mesh = scene->mMeshes[m];
    if (out.vertexCount() + mesh->mNumVertices > std::numeric_limits<std::uint32_t>::max()) {
      out = SceneMesh();
      return {LoadError::kTooLarge, "loadMesh: '" + path + "' has more than 2^32 - 1 vertices"};
    }
    const auto base = static_cast<std::uint32_t>(out.vertexCount());
    for (unsigned v = 0; v < mesh->mNumVertices; ++v) {
      const aiVector3D& p = mesh->mVertices[v];
      const Vec3 q(static_cast<double>(p.x), static_cast<double>(p.y), static_cast<double>(p.z));
      if (!q.allFinite()) {
        out = SceneMesh();
        return {LoadError::kNonFinite, "loadMesh: '" + path + "': mesh " + std::to_string(m) + " vertex " +
                                           std::to_string(v) + " is not finite"};
      }
      out.addVertex(q);
    }
    for (unsigned f = 0; f < mesh->mNumFaces; ++f) {
      const aiFace& face = mesh->mFaces[f];
      if (face.mNumIndices != 3) {
        ++skipped;  // a point or a line (Triangulate leaves those)
        continue;
      }
      bool valid = true;
      for (int k = 0; k < 3; ++k) valid = valid && face.mIndices[k] < mesh->mNumVertices;
      if (!valid) {
        out = SceneMesh();
        return {LoadError::kParseError, "loadMesh: '" + path + "': mesh " + std::to_string(m) + " face " +
                                            std::to_string(f) + " indexes a missing vertex"};
      }
      out.addTriangle(base + face.mIndices[0], base + face.mIndices[1], base + face.mIndices[2]);
    }
  }
  if (info) {
    info->meshes = scene->mNumMeshes;
    info->skipped_primitives = skipped;
  }
  if (out.triangleCount() == 0) {
    out = SceneMesh();
    return {LoadError::kNoTriangles, "loadMesh: '" + path + "' holds no triangle"};
  }
  return {};
}

}  // namespace meshcontact::scenes
