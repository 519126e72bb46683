#include "MeshFile.h"

#include "../core/Error.h"
#include "../core/OneLine.h"

#include <assimp/DefaultIOSystem.h>
#include <assimp/Importer.hpp>
#include <assimp/postprocess.h>
#include <assimp/scene.h>

#include <algorithm>
#include <array>
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

// Assimp 5.2's OBJ reader, as far as positions and the indices naming them go: objIndexProblem
// (below) must see the lines Assimp sees and count the positions Assimp keeps. The rules are read
// from Assimp 5.2.5 (tag v5.2.5: include/assimp/IOStreamBuffer.h, include/assimp/ParsingUtils.h,
// code/AssetLib/Obj/ObjFileParser.cpp, ObjTools.h, ObjFileImporter.cpp) and each one checked
// against Debian 12's libassimp 5.2.5 on hand-written files (test_mesh_file.cpp).

// ParsingUtils.h: IsLineEnd, the bytes that end an OBJ line for Assimp, and IsSpace, its blanks.
bool objLineEnd(char c)
{
    return c == '\n' || c == '\r' || c == '\0' || c == '\f';
}

bool objBlank(char c)
{
    return c == ' ' || c == '\t';
}

// Whether line starts with the word w (ObjTools.h getNameNoSpace: the bytes up to a blank or a line end).
bool objWord(const char* line, const char* w)
{
    const size_t n = std::strlen(w);
    return std::strncmp(line, w, n) == 0 && (objBlank(line[n]) || objLineEnd(line[n]));
}

// An OBJ file's lines as ObjFileParser::parseFile gets them from
// IOStreamBuffer<char>::getNextDataLine(buffer, '\\'): a line ends at any objLineEnd byte (CRLF is a
// line and an empty one); a '\' before a line end joins the next line on, from the byte after the
// next '\n', and that byte is taken whatever it is (a line end too). Every line is written into one
// buffer, over the last, with a '\n' after it; past that '\n' lie the leftovers of earlier, longer
// lines (zeros at first), which Assimp's tokenisers read on into after a '\' before a line end. Assimp
// reads the file in blocks of 16 MiB (4096 * 4096, IOStreamBuffer's cache); in a larger file a last
// line with no line end is dropped. Not followed: in such a file, a '\' continuation that runs past
// the end of a block (Assimp reads outside its block there).
class ObjLines {
public:
    explicit ObjLines(const std::string& text) : text_(text), buffer_(256, '\0') {}

    // The next line into line(); false when there is none.
    bool next();
    // The line, '\n', the leftovers, then '\0' up to size().
    const char* line() const { return buffer_.data(); }
    size_t size() const { return buffer_.size(); }
    // Where in the file the line began.
    size_t start() const { return start_; }

private:
    // A byte of the file; Assimp's cache holds '\n' past the end of a file under 16 MiB.
    char at(size_t i) const { return i < text_.size() ? text_[i] : '\n'; }
    // Writes n bytes at i; a '\0' stays past every byte ever written.
    void put(size_t i, const char* bytes, size_t n)
    {
        while (i + n >= buffer_.size())
            buffer_.resize(2 * buffer_.size(), '\0');
        std::memcpy(&buffer_[i], bytes, n);
    }
    // The bytes next() stops at: the line ends and '\'.
    static constexpr std::array<bool, 256> kSpecial = [] {
        std::array<bool, 256> special{};
        for (const unsigned char c : {'\n', '\r', '\0', '\f', '\\'})
            special[c] = true;
        return special;
    }();

    const std::string& text_;
    std::string buffer_;
    size_t pos_ = 0, start_ = 0;
};

bool ObjLines::next()
{
    const size_t size = text_.size();
    if (pos_ >= size)
        return false;
    start_ = pos_;
    size_t length = 0;
    for (;;) {
        // The bytes up to the next line end or '\' at once, where Assimp takes them one by one.
        size_t run = pos_;
        while (run < size && !kSpecial[static_cast<unsigned char>(text_[run])])
            ++run;
        if (run > pos_) {
            put(length, text_.data() + pos_, run - pos_);
            length += run - pos_;
            pos_ = run;
        } else {
            const char c = text_[pos_];
            if (c == '\\' && objLineEnd(at(pos_ + 1))) {
                ++pos_;
                while (at(pos_) != '\n')
                    ++pos_;
                ++pos_;
            } else if (objLineEnd(c)) {
                break;
            }
            const char taken = at(pos_);  // the '\', or the byte after the continuation, whatever it is
            put(length++, &taken, 1);
            ++pos_;
        }
        if (pos_ >= size) {
            if (size > size_t(4096) * 4096)
                return false;  // the file read in blocks: the next block is not there, the line is lost
            break;
        }
    }
    const char end = '\n';
    put(length, &end, 1);
    ++pos_;
    return true;
}

// The components Assimp 5.2 counts on a 'v' line, from p, the blank after the 'v'
// (ObjFileParser::getNumComponentsInDataDefinition): the words between blanks up to a line end, a
// word '\' before a line end stepped over with it (on into the buffer's leftovers); a word counts
// when it starts with a digit, '+' or '-', or with "nan" or "inf" in any case ("info" counts;
// ".5", "#" and "x" do not, so "v 1 2 3 # 4" has four, "v .5 .5 .5" none).
int objComponents(const char* p)
{
    const auto lower = [](char c) { return char(std::tolower(static_cast<unsigned char>(c))); };
    const auto starts = [&](const char* w) {  // stops at the first byte that differs
        return lower(p[0]) == w[0] && lower(p[1]) == w[1] && lower(p[2]) == w[2];
    };
    int count = 0;
    for (;;) {
        if (p[0] == '\\' && objLineEnd(p[1]))
            p += 2;
        while (objBlank(*p))
            ++p;
        if (objLineEnd(*p))
            return count;
        const bool number = (*p >= '0' && *p <= '9') || *p == '+' || *p == '-' || starts("nan") || starts("inf");
        while (!objBlank(*p) && !objLineEnd(*p))
            ++p;
        count += number;
        while (objBlank(*p))
            ++p;
        if (objLineEnd(*p))
            return count;
    }
}

// glibc's atoi, with which Assimp 5.2 reads a face's indices: strtol, cut to int (GCC keeps the low
// 32 bits). A sign and up to 9 digits are read here; white space first, no digit or 10 digits and
// more go to strtol itself (p's buffer ends in a '\0').
int objAtoi(const char* p)
{
    const bool negative = *p == '-';
    const char* q = p + (negative || *p == '+');
    int value = 0, digits = 0;
    for (; digits < 9 && *q >= '0' && *q <= '9'; ++q, ++digits)
        value = value * 10 + (*q - '0');
    if (digits > 0 && !(*q >= '0' && *q <= '9'))
        return negative ? -value : value;
    return int(std::strtol(p, nullptr, 10));
}

// The position indices of a face, line or point statement (any line that starts with 'f', 'l' or
// 'p', "fo" and "lod" too) as ObjFileParser::getFace walks it, in line, the buffer of `size` bytes
// that holds it: the first word skipped, then byte by byte up to a line end. A '/' moves to the
// corner's next field (texture coordinate, normal; the second is the normal's when the file has
// normals and no texture coordinates yet), a blank back to the position; any other byte is read
// there by atoi, and the walk moves on by the value's digits (and its '-'), not by the word's bytes:
// "1-2" is 1 then -2, "01" is 1 twice, and atoi skips white space ('\v', a line end after it). A
// value in a fourth field makes Assimp skip to the buffer's next line (reportErrorTokenInFace) and
// walk on there, in the leftovers, or past the buffer's end where the line fills it (a file of one
// line: an over-read that ASan reports in Assimp's strtol): such a face is no OBJ (a corner has
// at most v/vt/vn), and the walk returns false for objIndexProblem to refuse the file. Calls
// position(value) for each value in the position's field until it returns false; stops at a 0,
// given to position too (atoi's answer to a word that is no number: Assimp throws "OBJ: Invalid
// face index." while parsing, before there is any mesh to leak).
template <class Position>
bool objFacePositions(const char* line, size_t size, bool texcoords, bool normals, Position&& position)
{
    // Past every byte ever written, Assimp's buffer holds zeros, as this one does (and past its size).
    const auto at = [&](size_t i) { return i < size ? line[i] : '\0'; };
    size_t i = 0;
    while (!objBlank(at(i)) && !objLineEnd(at(i)))
        ++i;
    while (objBlank(at(i)))
        ++i;
    int field = 0;
    while (!objLineEnd(at(i))) {
        size_t step = 1;
        if (line[i] == '/') {
            ++field;
        } else if (objBlank(line[i])) {
            field = 0;
        } else {
            const int value = objAtoi(line + i);
            if (value < 0)
                ++step;
            for (int rest = value; (rest /= 10) != 0;)
                ++step;
            if (field == 1 && !texcoords && normals)
                field = 2;
            if (value == 0) {
                position(0);
                return true;
            }
            if (field > 2)
                return false;  // a fourth field: refused (objIndexProblem)
            if (field == 0 && !position(value))
                return true;
        }
        i += step;
    }
    return true;
}

// The 1-based line of the file at offset, as an editor counts lines ("\r\n", "\n" or "\r" ends one).
long long objLineNumber(const std::string& text, size_t offset)
{
    long long line = 1;
    for (size_t i = 0; i < offset; ++i)
        line += text[i] == '\n' || (text[i] == '\r' && (i + 1 >= text.size() || text[i + 1] != '\n'));
    return line;
}

// An OBJ file's face, line and point position indices, checked before Assimp reads it. Assimp 5.2
// finds an index past the file's positions only after it has allocated the mesh it copies them
// into, and throws "OBJ: vertex index out of range" leaving meshes behind (fuzz_mesh: a leak of
// 1.3-1.6 KB per file, more with the group's faces; in a host application, per load). The positions
// are counted as Assimp 5.2 counts them (ObjLines, above, and ObjFileParser::parseFile): a line is
// a position when its first byte is 'v' and its second a blank (an indented line is none: Assimp
// skips no blank before the keyword) and it holds 3, 4 (homogeneous) or 6 (a colour after it)
// components as objComponents counts them; any
// other count is skipped without a word ("v 30 0", two: fuzz_mesh, 1,552 bytes leaked); the lines
// from one starting with the word "cstype" to one starting with "end" are skipped whole, faces too.
// A positive index i names position i (1-based) of the whole file, a negative one the position |i|
// before the line's (ObjFileImporter::createVertexArray refuses what falls outside). The count is
// exact, not a bound: one position too many would let a leak through, one too few would refuse a
// file that Assimp reads, and no file that Assimp reads is refused here: only indices that Assimp
// reads as positions are looked at (objFacePositions), and Assimp checks every one of them (a 0 and
// a word that is no number are left to Assimp's own error). Returns why not, or "".
std::string objIndexProblem(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    const std::string text = restOf(in);
    ObjLines lines(text);
    long long seen = 0;  // positions before the line
    long long largest = 0, relative = 0;
    size_t largestAt = 0;  // the largest positive index, and the line it is on
    char largestKind = 'f';
    bool texcoords = false, normals = false, curves = false;
    while (lines.next()) {
        const char* line = lines.line();
        if (curves) {
            curves = !objWord(line, "end");
            continue;
        }
        const char k = line[0];
        if (k == 'v') {
            if (objBlank(line[1])) {
                const int components = objComponents(line + 1);
                seen += components == 3 || components == 4 || components == 6;
            }
            texcoords |= line[1] == 't';
            normals |= line[1] == 'n';
        } else if (k == 'c') {
            curves = objWord(line, "cstype");
        } else if (k == 'f' || k == 'l' || k == 'p') {
            int corners = 0;
            bool zero = false;  // Assimp's own error
            const bool threeFields = objFacePositions(line, lines.size(), texcoords, normals, [&](int i) {
                zero |= i == 0;
                ++corners;
                if (i < 0 && i < -seen) {
                    relative = i;
                    return false;
                }
                if (i > largest)
                    largest = i, largestAt = lines.start(), largestKind = k;
                return true;
            });
            if (!threeFields)
                return "line " + std::to_string(objLineNumber(text, lines.start())) + " ('" + std::string(1, k) +
                       "') has a corner of more than three fields (position/texture/normal) (damaged)";
            // A line of one corner: Assimp 5.2 counts a line's segments (corners - 1, none here) but
            // copies its corners, and throws "OBJ: no vertices" or "OBJ: bad vertex index" after the
            // meshes of the groups before it are made, which it leaks (fuzz_mesh: "p 1", "g 4",
            // "l 2", 1,552 bytes). Assimp reads no file with such a line.
            if (k == 'l' && corners == 1 && !zero)
                return "line " + std::to_string(objLineNumber(text, lines.start())) +
                       " ('l') has one corner; a line needs two or more (damaged)";
            if (relative != 0)
                return "line " + std::to_string(objLineNumber(text, lines.start())) + " ('" + std::string(1, k) +
                       "') names position " + std::to_string(relative) + " (relative) after " + std::to_string(seen) +
                       " positions (damaged)";
        }
    }
    if (largest > seen)
        return "line " + std::to_string(objLineNumber(text, largestAt)) + " ('" + std::string(1, largestKind) +
               "') names position " + std::to_string(largest) + " of a file of " + std::to_string(seen) +
               " positions (damaged)";
    return "";
}

// The files Assimp may open: the mesh file, and nothing else. An OBJ's "mtllib" names a material
// library, which nimbus drops (aiComponent_MATERIALS below), and Assimp 5.2 opens whatever the
// name resolves to: one that ends in '/' or is "." or ".." resolves to a folder, whose read fails
// with "File read error" after the stream is open, and the stream leaks (fuzz_mesh: "mtllib miss/"
// after a face, 56 bytes per load; the CI's smoke run found it); a FIFO or a device named there
// would be read too. Here the library is not found, which Assimp skips with a log line.
class MeshFileOnly : public Assimp::DefaultIOSystem {
public:
    explicit MeshFileOnly(std::string path) : mPath(std::move(path)) {}
    bool Exists(const char* file) const override { return isMeshFile(file) && DefaultIOSystem::Exists(file); }
    Assimp::IOStream* Open(const char* file, const char* mode = "rb") override
    {
        return isMeshFile(file) ? DefaultIOSystem::Open(file, mode) : nullptr;
    }

private:
    bool isMeshFile(const char* file) const
    {
        if (!file)
            return false;
        if (mPath == file)
            return true;
        std::error_code ec;
        return std::filesystem::equivalent(mPath, file, ec) && !ec;
    }
    std::string mPath;
};

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
    importer.SetIOHandler(new MeshFileOnly(path));  // the importer owns it
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
