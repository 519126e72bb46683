#include "MeshFile.h"

#include "../core/Error.h"
#include "../core/OneLine.h"

#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <system_error>

namespace nimbus {

namespace {

std::string lowerExtension(const std::string& path)
{
    std::string ext = std::filesystem::path(path).extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext;
}

// Up to 80 bytes of a header line for a message: a NUL or another control byte escaped, a byte
// outside ASCII as \xNN (a NUL cut the CLI's error line short: fuzz_mesh, "property a\0"; binary
// first lines would make it invalid UTF-8).
std::string quotedLine(const std::string& line)
{
    return oneLine(line.substr(0, 80), /*asciiOnly=*/true);
}

// What is left of `in`, whole (Assimp reads the whole file into memory too).
std::string restOf(std::istream& in)
{
    std::ostringstream rest;
    rest << in.rdbuf();
    return rest.str();
}

// A PLY file's header, checked before Assimp reads it: every line one PLY keyword with its
// operands, and the elements' records able to fit in the file. Assimp 5.2 takes an unknown
// header line for a property of no type, then hangs or crashes reading the data (fuzz_mesh: a
// 218-byte file, "properend_header", SIGSEGV in nimbus render), and reserves whatever count an
// element claims. Returns why not, or "".
std::string plyHeaderProblem(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    std::string line;
    // A .ply file's first line must be "ply" itself. Assimp 5.2 reads a file whose first line
    // only starts with "ply" ("plyply", "plyA") as PLY, unchecked here before, and spent over
    // 25 s on 67- and 248-byte ones (fuzz_mesh timeouts).
    if (!std::getline(in, line) || (line != "ply" && line != "ply\r")) {
        if (!line.empty() && line.back() == '\r')
            line.pop_back();
        return "its first line '" + quotedLine(line) + "' is not 'ply' (not a PLY file, or damaged)";
    }
    const std::streampos header = in.tellg();
    in.seekg(0, std::ios::end);
    const double fileSize = double(in.tellg());
    in.seekg(header);
    static const std::map<std::string, int> kTypeBytes = {
        {"char", 1},  {"uchar", 1},  {"int8", 1},  {"uint8", 1},  {"short", 2},   {"ushort", 2},
        {"int16", 2}, {"uint16", 2}, {"int", 4},   {"uint", 4},   {"int32", 4},   {"uint32", 4},
        {"float", 4}, {"float32", 4}, {"double", 8}, {"float64", 8}};
    bool binary = false, ended = false;
    double minimumBytes = 0.0, count = 0.0, recordBytes = 0.0;  // of the element being declared
    for (int n = 2; !ended && std::getline(in, line); ++n) {
        if (!line.empty() && line.back() == '\r')
            line.pop_back();
        std::istringstream words(line);
        std::string keyword, a, b, c, rest;
        words >> keyword;
        const auto isType = [](const std::string& t) { return kTypeBytes.count(t) > 0; };
        bool ok = true;
        if (keyword == "comment" || keyword == "obj_info") {
        } else if (keyword == "format") {
            ok = bool(words >> a >> b) && !(words >> rest) &&
                 (a == "ascii" || a == "binary_little_endian" || a == "binary_big_endian");
            binary = a != "ascii";
        } else if (keyword == "element") {
            long long elements = -1;
            ok = bool(words >> a >> elements) && elements >= 0 && !(words >> rest);
            minimumBytes += count * std::max(recordBytes, binary ? 0.0 : 1.0);
            count = double(elements), recordBytes = 0.0;
        } else if (keyword == "property") {
            ok = bool(words >> a >> b);
            // The sizes only of types checked above: kTypeBytes.at() of an unknown type threw
            // std::out_of_range (fuzz_mesh: "property a \0" in a binary header, exit 1).
            if (ok && a == "list") {
                ok = isType(b) && bool(words >> c >> rest) && isType(c) && !(words >> a);
                if (ok)
                    recordBytes += binary ? kTypeBytes.at(b) : 2.0;  // the list's length at least
            } else if (ok) {
                ok = isType(a) && !(words >> rest);
                if (ok)
                    recordBytes += binary ? kTypeBytes.at(a) : 2.0;  // a number and a separator
            }
        } else if (keyword == "end_header") {
            ended = words >> rest ? false : true;
            ok = ended;
        } else {
            ok = false;
        }
        if (!ok)
            return "PLY header line " + std::to_string(n) + " '" + quotedLine(line) +
                   "' is not a PLY header line (damaged)";
        if (n > 100000)
            break;
    }
    if (!ended)
        return "its PLY header has no end_header line (truncated or damaged)";
    minimumBytes += count * std::max(recordBytes, binary ? 0.0 : 1.0);
    const double left = fileSize - double(in.tellg());
    if (minimumBytes > left)
        return "its PLY header describes at least " + std::to_string((long long)std::min(minimumBytes, 9e18)) +
               " bytes of elements where " + std::to_string((long long)left) + " are left (truncated or damaged)";
    if (!binary) {
        // ASCII data: every value a number. Assimp 5.2 throws "Cannot parse string ... as a real
        // number" after allocating the element it reads into, and leaks it (fuzz_mesh: "0nt" in the
        // data, 1,368 bytes a load). strtod reads at least what Assimp's parser reads (it also takes
        // inf, nan and hexadecimal), so no file that Assimp reads is refused.
        const std::string data = restOf(in);
        long long dataLine = 1;
        for (size_t i = 0; i < data.size();) {
            const char ch = data[i];
            if (ch == '\n' || ch == ' ' || ch == '\t' || ch == '\r') {
                dataLine += ch == '\n';
                ++i;
                continue;
            }
            size_t j = i;
            while (j < data.size() && data[j] != '\n' && data[j] != ' ' && data[j] != '\t' && data[j] != '\r')
                ++j;
            // strtod stops at the token's end (a blank is never part of a number), or before it.
            char* stop = nullptr;
            std::strtod(data.c_str() + i, &stop);
            if (stop != data.c_str() + j)
                return "PLY data line " + std::to_string(dataLine) + ": '" + quotedLine(data.substr(i, j - i)) +
                       "' is not a number (damaged)";
            i = j;
        }
    }
    return "";
}

// An OBJ file's face, line and point position indices, checked before Assimp reads it. Assimp 5.2
// finds an index past the file's vertices only after it has allocated the mesh it copies them
// into, and throws "OBJ: vertex index out of range" leaving that mesh behind (fuzz_mesh: a leak of
// 1.3-1.6 KB per file, more with the group's faces; in a host application, per load). As Assimp
// reads them: every line "v ..." is one position; a positive index i names position i (1-based) of
// the whole file, a negative one the position |i| before the line's. Only indices Assimp would
// refuse are refused: an index of 0 or one that is not a number is left to Assimp's own error.
// Returns why not, or "".
std::string objIndexProblem(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    const std::string text = restOf(in);
    long long seen = 0, lineNo = 0;          // positions before the line; the line's number
    long long largest = 0, largestLine = 0;  // the largest positive index, and where
    char largestKind = 'f';
    const char* p = text.data();
    const char* const end = p + text.size();
    auto blank = [](char c) { return c == ' ' || c == '\t' || c == '\r'; };
    while (p < end) {
        const char* eol = static_cast<const char*>(std::memchr(p, '\n', size_t(end - p)));
        if (!eol)
            eol = end;
        ++lineNo;
        while (p < eol && (*p == ' ' || *p == '\t'))
            ++p;
        const char k = p < eol ? *p : 0;
        if (p + 1 < eol && blank(p[1]) && (k == 'v' || k == 'f' || k == 'l' || k == 'p')) {
            if (k == 'v') {
                ++seen;
            } else {
                // The position index opens each token (v, v/vt, v//vn, v/vt/vn).
                for (const char* q = p + 1; q < eol;) {
                    while (q < eol && blank(*q))
                        ++q;
                    const char* token = q;
                    while (q < eol && !blank(*q))
                        ++q;
                    if (token == q)
                        break;
                    char* stop = nullptr;
                    const long long i = std::strtoll(token, &stop, 10);
                    if (stop == token || stop > q || i == 0)
                        continue;  // not a number (strtoll skipped past the token), or 0
                    if (i < 0 && i < -seen)  // (not -i > seen: -LLONG_MIN overflows)
                        return "line " + std::to_string(lineNo) + " ('" + std::string(1, k) + "') names position " +
                               std::to_string(i) + " (relative) after " + std::to_string(seen) +
                               " positions (damaged)";
                    if (i > largest)
                        largest = i, largestLine = lineNo, largestKind = k;
                }
            }
        }
        p = eol + 1;
    }
    if (largest > seen)
        return "line " + std::to_string(largestLine) + " ('" + std::string(1, largestKind) + "') names position " +
               std::to_string(largest) + " of a file of " + std::to_string(seen) + " positions (damaged)";
    return "";
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

    {
        const std::string problem = ext == ".ply" ? plyHeaderProblem(path) : objIndexProblem(path);
        if (!problem.empty())
            throw InputError(key + ": cannot read mesh " + quoted + ": " + problem);
    }

    Assimp::Importer importer;
    // Only positions and faces: drop normals, UVs, colours, materials before the post-steps.
    importer.SetPropertyInteger(AI_CONFIG_PP_RVC_FLAGS, aiComponent_NORMALS | aiComponent_TANGENTS_AND_BITANGENTS |
                                                            aiComponent_COLORS | aiComponent_TEXCOORDS |
                                                            aiComponent_MATERIALS | aiComponent_TEXTURES);
    // OBJ faces index shared positions already, and Assimp's importer keeps one vertex per face
    // corner; welding them back (aiProcess_JoinIdenticalVertices) hashes every corner and was
    // most of a 100k-triangle mesh's load time, for memory nimbus does not need back.
    //
    // Read, validated, then checked, and only then post-processed: Assimp 5.2's post-steps trust
    // the importer's faces. A face whose index is past the vertices crashed aiProcess_Triangulate
    // (SIGSEGV) and a face of no indices (a binary PLY list of length 0, a truncated ASCII one)
    // failed its ai_assert (abort); aiProcess_ValidateDataStructure refuses the first, the loop
    // below the second (fuzz_mesh, docs/robustness.md).
    const auto failed = [&](const char* what) {
        std::string why = what;
        std::replace(why.begin(), why.end(), '\n', ' ');
        return InputError(key + ": cannot read mesh " + quoted + ": " + (why.empty() ? "unreadable" : why));
    };
    const aiScene* scene = nullptr;
    try {
        scene = importer.ReadFile(path, aiProcess_ValidateDataStructure);
        if (!scene)
            throw failed(importer.GetErrorString());
        for (unsigned m = 0; m < scene->mNumMeshes; ++m) {
            const aiMesh* am = scene->mMeshes[m];
            for (unsigned f = 0; f < am->mNumFaces; ++f)
                if (am->mFaces[f].mNumIndices == 0 || !am->mFaces[f].mIndices)
                    throw InputError(key + ": mesh " + quoted + ": face " + std::to_string(f) + " of mesh " +
                                     std::to_string(m) + " has no vertices (damaged)");
        }
        scene = importer.ApplyPostProcessing(aiProcess_RemoveComponent | aiProcess_Triangulate |
                                             aiProcess_PreTransformVertices);
        if (!scene)
            throw failed(importer.GetErrorString());
    } catch (const InputError&) {
        throw;
    } catch (const std::exception& e) {
        // Assimp reports through GetErrorString; anything it throws past that is the file's too.
        throw failed(e.what());
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
