#pragma once
// The shapes of the FCL benchmarks (fcl_bench.cpp, fcl_broadphase_bench.cpp),
// one definition for both.
#include <meshcontact_scenes/fcl_models.h>

#include <memory>

namespace fclbench {

enum ShapeId { kSphere = 0, kCapsule, kBox, kCylinder, kConvex, kCone, kEllipsoid, kShapeCount };
inline const char* const kShapeNames[] = {"Sphere", "Capsule", "Box", "Cylinder", "Convex", "Cone", "Ellipsoid"};

// Sphere r 0.25, capsule r 0.15 lz 0.5, box 0.6 x 0.4 x 0.3, cylinder r 0.25
// lz 0.4, convex: a hexagonal prism (circumradius 0.3, height 0.4), cone r
// 0.3 lz 0.5, ellipsoid radii 0.35, 0.25, 0.15.
inline std::shared_ptr<::fcl::CollisionGeometryd> makeShape(ShapeId id) {
  switch (id) {
    case kSphere: return std::make_shared<::fcl::Sphered>(0.25);
    case kCapsule: return std::make_shared<::fcl::Capsuled>(0.15, 0.5);
    case kBox: return std::make_shared<::fcl::Boxd>(0.6, 0.4, 0.3);
    case kCylinder: return std::make_shared<::fcl::Cylinderd>(0.25, 0.4);
    case kConvex: return meshcontact::scenes::fclHexPrism(0.3, 0.2);
    case kCone: return std::make_shared<::fcl::Coned>(0.3, 0.5);
    case kEllipsoid: return std::make_shared<::fcl::Ellipsoidd>(0.35, 0.25, 0.15);
    case kShapeCount: break;
  }
  return nullptr;
}

// Half the shape's largest extent.
inline double halfSize(ShapeId id) {
  switch (id) {
    case kSphere: return 0.25;
    case kCapsule: return 0.4;
    case kBox: return 0.3;
    case kCylinder: return 0.25;
    case kConvex: return 0.3;
    case kCone: return 0.3;
    case kEllipsoid: return 0.35;
    case kShapeCount: break;
  }
  return 0.0;
}

}  // namespace fclbench
