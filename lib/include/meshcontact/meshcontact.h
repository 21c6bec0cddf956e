#pragma once
// Umbrella header.
#include "meshcontact/contact.h"
#include "meshcontact/convex.h"
#include "meshcontact/geometry.h"
#include "meshcontact/mesh.h"
#include "meshcontact/query.h"
#include "meshcontact/status.h"
#include "meshcontact/triangle.h"
