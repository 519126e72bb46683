#include "MeshFile.h"

#include "../core/Error.h"

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <system_error>

namespace nimbus {

namespace {

std::string lowerExtension(const std::string& path)
{
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

}  // namespace

TriangleMesh readMeshFile(const std::string& path, const std::string& key)
{
    const std::string quoted = "'" + path + "'";
    const std::string ext = lowerExtension(path);
    if (ext != ".obj" && ext != ".ply")
        throw InputError(key + ": " + quoted + " is not an OBJ or PLY file (expected the extension .obj or .ply)");
    std::error_code ec;
    if (!std::filesystem::exists(path, ec))
        throw InputError(key + ": cannot open " + quoted + ": no such file");
    if (!std::filesystem::is_regular_file(path, ec))
        throw InputError(key + ": cannot open " + quoted + ": not a regular file");

    Assimp::Importer importer;
    // Only positions and faces: drop normals, UVs, colours, materials before the post-steps.
    importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS, aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS |
                                                            aiComponent_COLORS | aiComponent_TEXCOORDS |
                                                            aiComponent_MATERIALS | aiComponent_TEXTURES);
    // OBJ faces index shared positions already, and Assimp's importer keeps one vertex per face
    // corner; welding them back (aiProcess_JoinIdenticalVertices) hashes every corner and was
    // most of a 100k-triangle mesh's load time, for memory nimbus does not need back.
    const aiScene* scene =
        importer.ReadFile(path, aiProcess_RemoveComponent | aiProcess_Triangulate | aiProcess_PreTransformVertices);
    if (!scene) {
        std::string why = importer.GetErrorString();
        std::replace(why.begin(), why.end(), '\n', ' ');
        throw InputError(key + ": cannot read mesh " + quoted + ": " + (why.empty() ? "unreadable" : why));
    }

    TriangleMesh mesh;
    for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
        const aiMesh* am = scene->mMeshes[m];
        const uint32_t base = uint32_t(mesh.positions.size());
        for (unsigned v = 0; v < am->mNumVertices; ++v) {
            const aiVector3D& p = am->mVertices[v];
            if (!std::isfinite(p.x) || !std::isfinite(p.y) || !std::isfinite(p.z))
                throw InputError(key + ": mesh " + quoted + ": vertex " + std::to_string(v) + " of mesh " +
                                 std::to_string(m) + " is not finite (" + std::to_string(p.x) + ", " +
                                 std::to_string(p.y) + ", " + std::to_string(p.z) + ")");
            mesh.positions.push_back(make_float3(p.x, p.y, p.z));
        }
        for (unsigned f = 0; f < am->mNumFaces; ++f) {
            const aiFace& face = am->mFaces[f];
            if (face.mNumIndices != 3)
                continue;  // points and lines: no surface
            for (int i = 0; i < 3; ++i) {
                if (face.mIndices[i] >= am->mNumVertices)
                    throw InputError(key + ": mesh " + quoted + ": face " + std::to_string(f) +
                                     " names a vertex that does not exist");
                mesh.indices.push_back(base + face.mIndices[i]);
            }
        }
    }
    if (mesh.indices.empty())
        throw InputError(key + ": mesh " + quoted + " has no triangles");
    return mesh;
}

}  // namespace nimbus
