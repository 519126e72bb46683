#include "ImageFileCheck.h"

#include "FormatBytes.h"

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

namespace nimbus {

namespace {

// Reads little-endian fields from the stream; any read past the end sets `bad`.
struct Reader {
    std::ifstream& in;
    bool bad = false;

    int32_t i32()
    {
        unsigned char b[4] = {};
        if (!in.read(reinterpret_cast<char*>(b), 4))
            bad = true;
        return int32_t(uint32_t(b[0]) | uint32_t(b[1]) << 8 | uint32_t(b[2]) << 16 | uint32_t(b[3]) << 24);
    }
    unsigned char u8()
    {
        char c = 0;
        if (!in.get(c))
            bad = true;
        return static_cast<unsigned char>(c);
    }
    // A NUL-terminated string of at most 255 bytes (OpenEXR's longest names); false if longer.
    bool name(std::string& out)
    {
        out.clear();
        for (;;) {
            char c = 0;
            if (!in.get(c)) {
                bad = true;
                return false;
            }
            if (c == '\0')
                return true;
            if (out.size() == 255)
                return false;
            out += c;
        }
    }
    uint64_t offset() { return uint64_t(std::max<std::streamoff>(0, in.tellg())); }
};

// Scanlines per chunk by compression (ImfCompression.h: NO, RLE, ZIPS, ZIP, PIZ, PXR24, B44,
// B44A, DWAA, DWAB), and the most a chunk's pixel bytes can exceed its stored bytes: deflate
// at most ~1032:1 (ZIPS, ZIP, PXR24 on 24-bit floats: 1376), run-length 64:1 (RLE), B44 32 bytes
// in 14 (float channels stored whole), B44A a flat block in 3, PIZ's Huffman run codes below
// deflate's bound, DWA's DCT keeps one of 64 coefficients of a flat block before deflate (each
// rounded up). Unknown codes: the most lenient.
int linesPerChunk(int compression)
{
    static const int lines[] = {1, 1, 1, 16, 32, 16, 32, 32, 32, 256};
    return compression >= 0 && compression < 10 ? lines[compression] : 256;
}
double maxRatio(int compression)
{
    static const double ratio[] = {1.0, 64.0, 1100.0, 1100.0, 4096.0, 1500.0, 4.0, 16.0, kMaxImageRatio, kMaxImageRatio};
    return compression >= 0 && compression < 10 ? ratio[compression] : kMaxImageRatio;
}

// A name from the file as it may appear in a message: printable ASCII kept, any other byte as
// \xNN (a damaged header's names are arbitrary bytes; a message is one line of valid UTF-8).
std::string printable(const std::string& name)
{
    std::string out;
    for (const unsigned char c : name) {
        if (c >= 0x20 && c < 0x7f && c != '\\') {
            out += char(c);
        } else {
            char hex[8];
            std::snprintf(hex, sizeof hex, "\\x%02x", unsigned(c));
            out += hex;
        }
    }
    return out;
}

std::string describe(const char* what, uint64_t claimed, uint64_t left)
{
    char line[256];
    std::snprintf(line, sizeof line, "%s %llu bytes where %llu are left (truncated or damaged)", what,
                  static_cast<unsigned long long>(claimed), static_cast<unsigned long long>(left));
    return line;
}

// One part's header: what the size checks need.
struct ExrPart {
    bool hasWindow = false;
    int64_t width = 0, height = 0;
    int compression = 0;
    int64_t tileX = 0, tileY = 0;   // > 0: tiled
    int64_t chunkCount = -1;        // multi-part and deep files state it
    double bytesPerPixel = 0.0;     // over the channels, subsampling included
    int64_t bytesPerTilePixel = 0;  // over the channels, no subsampling (tiles have none)
    bool deep = false;
};

// The bytes OpenEXR 3.1's C++ reader takes for a value of a fixed-size type, whatever the
// attribute's size field says (TypedAttribute<T>::readValueFrom reads a T); 0: not fixed.
int fixedValueSize(const std::string& type)
{
    static const struct {
        const char* type;
        int size;
    } sizes[] = {{"box2i", 16},  {"box2f", 16},          {"chromaticities", 32}, {"compression", 1},
                 {"deepImageState", 1}, {"double", 8},   {"envmap", 1},          {"float", 4},
                 {"int", 4},     {"keycode", 28},        {"lineOrder", 1},       {"m33f", 36},
                 {"m33d", 72},   {"m44f", 64},           {"m44d", 128},          {"rational", 8},
                 {"tiledesc", 9}, {"timecode", 8},       {"v2i", 8},             {"v2f", 8},
                 {"v2d", 16},    {"v3i", 12},            {"v3f", 12},            {"v3d", 24}};
    for (const auto& s : sizes)
        if (type == s.type)
            return s.size;
    return 0;
}

// A tile's pixels, unclipped: OpenEXR allocates the tile buffers and the compressor's at this
// size when the file is opened, before a byte of them is read (fuzz_depth, bug 8: 1 GB in
// newTileCompressor for a 508-byte file). 64 MiB is a 2048 x 2048 tile of four 32-bit channels;
// files use 32 to 256 pixels a side.
constexpr int64_t maxTileBytes = int64_t(64) << 20;

std::string exrProblem(std::ifstream& in, uint64_t fileSize)
{
    Reader r{in};
    const int32_t version = r.i32();
    const bool multipart = version & 0x1000;
    double chunkTableBytes = 0.0;
    for (;;) {
        ExrPart p;
        bool any = false;
        std::string name, type;
        for (;;) {
            if (!r.name(name))
                return r.bad ? "its header ends early (truncated)" : "a header attribute name is longer than 255 bytes";
            if (name.empty())
                break;
            any = true;
            if (!r.name(type))
                return r.bad ? "its header ends early (truncated)" : "a header type name is longer than 255 bytes";
            const int32_t size = r.i32();
            const uint64_t here = r.offset(), left = here <= fileSize ? fileSize - here : 0;
            if (r.bad)
                return "its header ends early (truncated)";
            if (size < 0 || uint64_t(size) > left)
                return describe(("its header attribute '" + printable(name) + "' claims").c_str(), uint64_t(uint32_t(size)),
                                left);
            const uint64_t end = here + uint64_t(size);
            // OpenEXR's C++ reader takes what a known type's value needs, not the size field
            // (a channel list up to its empty name, a fixed-size value whole, a preview its
            // width x height pixels): where the two differ, the rest of the header is read from
            // another place than this walk reads it (fuzz bug 9: a channel list 'of 55 bytes'
            // that ends elsewhere, then an opaque attribute of 842 MB in a 204-byte file). Such
            // a header is refused: what OpenEXR reads must be what is checked here.
            const auto disagrees = [&](uint64_t takes) {
                char line[512];
                std::snprintf(line, sizeof line,
                              "its header attribute '%s' (%s) says %lld bytes but its value takes %llu (damaged)",
                              printable(name).c_str(), printable(type).c_str(), static_cast<long long>(size),
                              static_cast<unsigned long long>(takes));
                return std::string(line);
            };
            if (const int fixed = fixedValueSize(type); fixed > 0 && size != fixed)
                return disagrees(uint64_t(fixed));
            if (type == "preview") {
                const uint64_t w = uint32_t(r.i32()), h = uint32_t(r.i32());
                if (r.bad || size < 8 || 8 + 4 * w * h != uint64_t(size))
                    return disagrees(8 + 4 * w * h);
            } else if (type == "stringvector") {
                uint64_t taken = 0;
                while (taken < uint64_t(size)) {
                    const int32_t n = r.i32();
                    taken += 4;
                    if (r.bad || n < 0 || uint64_t(n) > uint64_t(size) - std::min<uint64_t>(taken, uint64_t(size)))
                        return disagrees(taken + uint64_t(uint32_t(n)));
                    taken += uint64_t(n);
                    in.seekg(std::streamoff(here + taken));
                }
                if (taken != uint64_t(size))
                    return disagrees(taken);
            } else if (type == "floatvector" && size % 4 != 0) {
                return disagrees(uint64_t(size / 4) * 4);
            }
            in.clear();
            in.seekg(std::streamoff(here));
            if (name == "dataWindow" && type == "box2i" && size == 16) {
                const int64_t x0 = r.i32(), y0 = r.i32(), x1 = r.i32(), y1 = r.i32();
                p.hasWindow = x1 >= x0 && y1 >= y0;
                p.width = x1 - x0 + 1, p.height = y1 - y0 + 1;
            } else if (name == "compression" && size == 1) {
                p.compression = r.u8();
            } else if (name == "tiles" && type == "tiledesc" && size == 9) {
                p.tileX = uint32_t(r.i32()), p.tileY = uint32_t(r.i32());
            } else if (name == "chunkCount" && size == 4) {
                p.chunkCount = r.i32();
            } else if (name == "type" && type == "string") {
                std::string value(size_t(size), '\0');
                in.read(&value[0], size);
                p.deep = value.compare(0, 4, "deep") == 0;
            } else if (type == "chlist") {
                // As OpenEXR reads it: up to the empty name, wherever the size field ends, and
                // whatever the attribute's name (it reads a value by its type: fuzz_envmap, a
                // 223-byte file whose "channel\x92s" list ran past its size field into a string
                // attribute of 2 GB). Only "channels" describes the pixels.
                const bool pixels = name == "channels";
                std::string channel;
                for (;;) {
                    if (!r.name(channel))
                        return r.bad ? "its header ends early (truncated)"
                                     : "a channel name is longer than 255 bytes";
                    if (channel.empty())
                        break;
                    const int32_t pixelType = r.i32();
                    r.i32();  // pLinear and reserved
                    const int64_t xs = std::max<int32_t>(1, r.i32()), ys = std::max<int32_t>(1, r.i32());
                    if (r.bad)
                        return "its header ends early (truncated)";
                    if (pixels) {
                        p.bytesPerPixel += (pixelType == 1 ? 2.0 : 4.0) / double(xs * ys);
                        p.bytesPerTilePixel += pixelType == 1 ? 2 : 4;
                    }
                }
                if (r.offset() != end)
                    return disagrees(r.offset() - here);
            }
            in.clear();
            in.seekg(std::streamoff(end));
            if (!in)
                return "its header ends early (truncated)";
        }
        if (!any)
            break;  // multi-part: the empty header after the last
        if (p.tileX > 0 && p.tileY > 0) {
            const double tileBytes = double(p.tileX) * double(p.tileY) * double(std::max<int64_t>(2, p.bytesPerTilePixel));
            if (tileBytes > double(maxTileBytes)) {
                char line[256];
                std::snprintf(line, sizeof line,
                              "its header attribute 'tiles' describes %lld x %lld pixel tiles (%.3g bytes a tile, "
                              "more than the %lld allowed; damaged)",
                              static_cast<long long>(p.tileX), static_cast<long long>(p.tileY), tileBytes,
                              static_cast<long long>(maxTileBytes));
                return line;
            }
        }
        if (p.hasWindow) {
            double chunks;
            if (p.chunkCount >= 0)
                chunks = double(p.chunkCount);
            else if (p.tileX > 0 && p.tileY > 0)
                chunks = double((p.width + p.tileX - 1) / p.tileX) * double((p.height + p.tileY - 1) / p.tileY);
            else
                chunks = double((p.height + linesPerChunk(p.compression) - 1) / linesPerChunk(p.compression));
            chunkTableBytes += 8.0 * chunks;
            const double pixelBytes = double(p.width) * double(p.height) * std::max(2.0, p.bytesPerPixel);
            if (!p.deep && pixelBytes > maxRatio(p.compression) * double(fileSize)) {
                char line[256];
                std::snprintf(line, sizeof line,
                              "its header describes %lld x %lld pixels (%.3g bytes), more than its %llu bytes can "
                              "hold (truncated or damaged)",
                              static_cast<long long>(p.width), static_cast<long long>(p.height), pixelBytes,
                              static_cast<unsigned long long>(fileSize));
                return line;
            }
        }
        if (!multipart)
            break;
    }
    const uint64_t here = r.offset(), left = here <= fileSize ? fileSize - here : 0;
    if (chunkTableBytes > double(left))
        return describe("its chunk offset table needs", uint64_t(std::min(chunkTableBytes, 1.8e19)), left);
    return "";
}

// Radiance RGBE: "#?RADIANCE" or "#?RGBE", header lines up to an empty one, then the size as
// "-Y H +X W" (or another orientation). Run-length coding stores at most 127 bytes in 2 (128:1
// counted on the 4-byte pixels, with room). Only the first 64 KiB are looked at.
std::string hdrProblem(std::ifstream& in, uint64_t fileSize)
{
    std::string head(65536, '\0');
    in.read(&head[0], std::streamsize(head.size()));
    head.resize(size_t(in.gcount()));
    const size_t blank = head.find("\n\n");
    if (blank == std::string::npos)
        return "";  // OpenImageIO refuses what has no header end or size line
    char a[3] = {}, b[3] = {};
    long long n1 = 0, n2 = 0;
    if (std::sscanf(head.c_str() + blank + 2, "%2s %lld %2s %lld", a, &n1, b, &n2) != 4 || n1 < 0 || n2 < 0)
        return "";
    const auto axis = [](const char* s) { return (s[0] == '-' || s[0] == '+') && (s[1] == 'X' || s[1] == 'Y'); };
    if (!axis(a) || !axis(b))
        return "";  // not a Radiance size line (another format's bytes)
    const double pixelBytes = 4.0 * double(n1) * double(n2);
    if (pixelBytes > 128.0 * double(fileSize)) {
        char out[256];
        std::snprintf(out, sizeof out,
                      "its header describes %lld x %lld pixels, more than its %llu bytes can hold (truncated or "
                      "damaged)",
                      n2, n1, static_cast<unsigned long long>(fileSize));
        return out;
    }
    return "";
}

}  // namespace

std::string imageHeaderProblem(const std::string& path)
{
    std::ifstream in(path, std::ios::binary);
    if (!in)
        return "";
    in.seekg(0, std::ios::end);
    const std::streamoff end = in.tellg();
    in.seekg(0);
    if (end <= 0)
        return "";
    const uint64_t fileSize = uint64_t(end);
    char magic[4] = {};
    if (!in.read(magic, 4))
        return "";
    if (std::memcmp(magic, "\x76\x2f\x31\x01", 4) == 0)
        return exrProblem(in, fileSize);
    // OpenImageIO 2.4's Radiance reader takes a header without its "#?" too (fuzz_envmap: a
    // "v/RADIANCE" file named .exr, which OpenEXR refuses and the .hdr reader then opens), so any
    // other file whose first 64 KiB hold a Radiance size line is held to the Radiance bound.
    in.seekg(0);
    return hdrProblem(in, fileSize);
}

std::string imagePixelsProblem(const std::string& path, int64_t width, int64_t height, int channels,
                               double loaderBytesPerPixel, size_t limitBytes)
{
    std::error_code ec;
    const uintmax_t fileSize = std::filesystem::file_size(path, ec);
    const double pixels = double(width) * double(height);
    char line[320];
    // Every format's pixels: 4 bytes a channel at the most lenient ratio of any (DWA's).
    if (!ec && pixels * 4.0 * double(std::max(1, channels)) > kMaxImageRatio * std::max(1.0, double(fileSize))) {
        std::snprintf(line, sizeof line,
                      "its header describes %lld x %lld pixels of %d channels, more than its %llu bytes can hold "
                      "(truncated or damaged)",
                      static_cast<long long>(width), static_cast<long long>(height), channels,
                      static_cast<unsigned long long>(fileSize));
        return line;
    }
    const double bytes = pixels * loaderBytesPerPixel;
    if (bytes > double(limitBytes)) {
        std::snprintf(line, sizeof line,
                      "its %lld x %lld pixels take %.3g bytes to load, more than render.memory_limit (%s); raise "
                      "render.memory_limit or give a smaller image",
                      static_cast<long long>(width), static_cast<long long>(height), bytes,
                      formatBytes(limitBytes).c_str());
        return line;
    }
    return "";
}

}  // namespace nimbus
