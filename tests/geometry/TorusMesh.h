// TorusMesh.h: a tessellated torus, the procedural occluder of the geometry tests and bench,
// and a plain OBJ writer for it (what a DCC exports: "v x y z" and "f a b c", 1-based).
#pragma once

#include "core/Vec.h"
#include "geometry/MeshFile.h"

#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>

namespace nimbus::test {

// 2 * ringSegments * tubeSegments triangles: the ring of radius R about the y axis, the tube of
// radius r, centred at the origin.
inline TriangleMesh torusMesh(float R, float r, int ringSegments, int tubeSegments)
{
    TriangleMesh m;
    for (int i = 0; i < ringSegments; ++i)
        for (int j = 0; j < tubeSegments; ++j) {
            const double u = 2.0 * M_PI * i / ringSegments, v = 2.0 * M_PI * j / tubeSegments;
            const double rho = R + r * std::cos(v);
            m.positions.push_back(make_float3(float(rho * std::cos(u)), float(r * std::sin(v)), float(rho * std::sin(u))));
        }
    auto at = [&](int i, int j) { return uint32_t((i % ringSegments) * tubeSegments + (j % tubeSegments)); };
    for (int i = 0; i < ringSegments; ++i)
        for (int j = 0; j < tubeSegments; ++j) {
            const uint32_t a = at(i, j), b = at(i + 1, j), c = at(i + 1, j + 1), d = at(i, j + 1);
            m.indices.insert(m.indices.end(), {a, b, c, a, c, d});
        }
    return m;
}

inline void writeObj(const TriangleMesh& m, const std::string& path)
{
    std::ofstream out(path);
    char line[96];
    for (const float3& p : m.positions) {
        std::snprintf(line, sizeof line, "v %.9g %.9g %.9g\n", p.x, p.y, p.z);
        out << line;
    }
    for (size_t t = 0; t < m.triangleCount(); ++t)
        out << "f " << m.indices[3 * t] + 1 << " " << m.indices[3 * t + 1] + 1 << " " << m.indices[3 * t + 2] + 1 << "\n";
}

}  // namespace nimbus::test
