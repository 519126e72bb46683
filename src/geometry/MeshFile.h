// MeshFile.h: the triangles of an OBJ or PLY file, read through Assimp (Debian's libassimp).
//
// nimbus needs only positions and triangles: geometry is opaque and unshaded (docs/geometry.md),
// so normals, UVs and materials are not read. Polygons are triangulated, the file's own node
// transforms are applied (PLY and OBJ rarely have any), points and lines are left out.
#pragma once

#include "../core/Vec.h"

#include <cstdint>
#include <string>
#include <vector>

namespace nimbus {

struct TriangleMesh {
    std::vector<float3> positions;  // object space, metres
    std::vector<uint32_t> indices;  // three per triangle, into positions
    size_t triangleCount() const { return indices.size() / 3; }
};

// Reads path (an .obj or .ply file). Every failure is an InputError "<key>: <what> '<path>'",
// key naming the scene value (e.g. "scene.json: geometry[0].file"): a missing or unreadable
// file, a format Assimp cannot parse, a file with no triangles, a position that is not finite.
TriangleMesh readMeshFile(const std::string& path, const std::string& key);

}  // namespace nimbus
