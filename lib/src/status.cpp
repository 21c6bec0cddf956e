#include "meshcontact/contact.h"
#include "meshcontact/geometry.h"
#include "meshcontact/status.h"

namespace meshcontact {

const char* toString(ErrorCode code) {
  switch (code) {
    case ErrorCode::kOk: return "Ok";
    case ErrorCode::kEmptyMesh: return "EmptyMesh";
    case ErrorCode::kIndexOutOfRange: return "IndexOutOfRange";
    case ErrorCode::kNonFiniteVertex: return "NonFiniteVertex";
    case ErrorCode::kMeshNotBuilt: return "MeshNotBuilt";
    case ErrorCode::kInvalidPose: return "InvalidPose";
    case ErrorCode::kInvalidShape: return "InvalidShape";
    case ErrorCode::kInvalidSettings: return "InvalidSettings";
    case ErrorCode::kTooLarge: return "TooLarge";
  }
  return "Unknown";
}

const char* toString(FeatureType type) {
  switch (type) {
    case FeatureType::kFace: return "Face";
    case FeatureType::kEdge: return "Edge";
    case FeatureType::kVertex: return "Vertex";
  }
  return "Unknown";
}

const char* toString(Verdict verdict) {
  switch (verdict) {
    case Verdict::kFaceContact: return "FaceContact";
    case Verdict::kEdgeContact: return "EdgeContact";
    case Verdict::kVertexContact: return "VertexContact";
    case Verdict::kVoided: return "Voided";
    case Verdict::kBackFacing: return "BackFacing";
    case Verdict::kBeyondContactDistance: return "BeyondContactDistance";
    case Verdict::kDegenerate: return "Degenerate";
  }
  return "Unknown";
}

}  // namespace meshcontact
