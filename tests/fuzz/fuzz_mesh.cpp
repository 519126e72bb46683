// fuzz_mesh: an OBJ or PLY file's bytes through the mesh loader (readMeshFile,
// src/geometry/MeshFile.h), as a scene's "mesh" geometry is read (issue 18, item 5).
//
// Input: the file's bytes; a file that starts with "ply" is read as .ply, any other as .obj (the
// loader, and Assimp within it, choose the reader by the extension). Besides "only InputError"
// (FuzzSupport.h), a mesh that loads must be what the loader promises and Embree relies on:
// at least one triangle, three indices each, every index inside the positions, every position
// finite.
//
// Assimp is Debian's GCC build, not instrumented: coverage is nimbus's side only; crashes and
// memory growth inside Assimp are seen. Corpus: tests/fuzz/corpus/mesh (hand-written files).
#include "FuzzSupport.h"

#include "geometry/MeshFile.h"

#include <cmath>
#include <cstring>
#include <string>

using namespace nimbus;

extern "C" int LLVMFuzzerInitialize(int*, char***)
{
    fuzz::quietLogs();
    return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size)
{
    const bool ply = size >= 3 && std::memcmp(data, "ply", 3) == 0;
    const std::string path = fuzz::writeInput(data, size, ply ? ".ply" : ".obj");
    fuzz::expectOnlyInputErrors([&] {
        const TriangleMesh mesh = readMeshFile(path, "fuzz: geometry[0].file");
        if (mesh.indices.empty() || mesh.indices.size() % 3 != 0)
            fuzz::finding("a mesh that loaded has " + std::to_string(mesh.indices.size()) + " indices");
        for (uint32_t i : mesh.indices)
            if (i >= mesh.positions.size())
                fuzz::finding("index " + std::to_string(i) + " past the " + std::to_string(mesh.positions.size()) +
                              " positions");
        for (const float3& p : mesh.positions)
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
                fuzz::finding("a position that is not finite");
    });
    return 0;
}
