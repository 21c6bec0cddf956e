#pragma once
// Explicit status for every fallible call of the library. The library throws
// no exception and reports nothing through stderr: a call either succeeds or
// returns a Status that says what was wrong with which input. (What it does
// not catch passes through: std::bad_alloc, and an exception thrown by user
// code it calls, a SupportShape's functions, convex.h.)

#include <string>
#include <utility>

namespace meshcontact {

enum class ErrorCode : unsigned char {
  kOk = 0,
  kEmptyMesh,         // no vertices or no triangles
  kIndexOutOfRange,   // a triangle references a vertex that does not exist
  kNonFiniteVertex,   // a vertex coordinate is NaN or infinite
  kMeshNotBuilt,      // a query was given a mesh whose build() did not succeed
  kInvalidPose,       // NaN/Inf in a pose, or a rotation that is not orthonormal
  kInvalidShape,      // NaN/Inf in a shape, negative or degenerate extent
  kInvalidSettings,   // negative or non-finite contact distance, bad option
  kTooLarge,          // more vertices or triangles than 32-bit indices address
};

/// Name of the code, e.g. "IndexOutOfRange" (for messages and tests).
const char* toString(ErrorCode code);

class [[nodiscard]] Status {
 public:
  Status() = default;  // ok
  Status(ErrorCode code, std::string message) : code_(code), message_(std::move(message)) {}

  static Status ok() { return Status(); }

  bool isOk() const { return code_ == ErrorCode::kOk; }
  explicit operator bool() const { return isOk(); }
  ErrorCode code() const { return code_; }
  /// Human-readable: which input, which index, which value. Empty when ok.
  const std::string& message() const { return message_; }

 private:
  ErrorCode code_ = ErrorCode::kOk;
  std::string message_;
};

}  // namespace meshcontact
