// NanoVdbFileReader.h: reads the grids of a NanoVDB file (.nvdb) as OpenVDB grids, so that a
// `vdb` source naming an .nvdb file goes through the same roles, clamping, shader and brick
// conversion as a .vdb file (issue 17, item 10; docs/volumes.md).
//
// The grids are read by NanoVDB's own I/O (nanovdb/util/IO.h: a file is segments, each a 16-byte
// header, one metadata record per grid, then the grids' buffers, raw or ZIP/BLOSC compressed)
// and converted by nanovdb::nanoToOpenVDB: the values, active states, tiles and the (double
// precision) index-to-world map come across unchanged, so an .nvdb made from a .vdb renders
// bit for bit like it. Quantised float grids (Fp4/8/16/N) become float grids.
//
// Why not nanovdb::io::readGrid on the file directly: like openvdb::io::File (VdbFileReader.h)
// it trusts the lengths it reads. A damaged name length allocates up to 4 GiB, a damaged grid
// size any amount, and a damaged compressed-block size is allocated before it is read. Here the
// segment headers and metadata are walked first with every length checked against the bytes
// left in the file; a grid's block (at most the file's size) is read into memory and its
// compressed chunk sizes checked against the block before NanoVDB decodes it from there; the
// decoded grid must claim the size its metadata did and pass NanoVDB's GridValidator (magic,
// version, checksum, node offsets inside the buffer) before anything walks its tree.
#pragma once

#include <openvdb/Grid.h>

#include <cstdint>
#include <string>
#include <vector>

namespace nimbus {

class NanoVdbFileReader {
public:
    // Reads and checks the file's segment headers and grid metadata. Throws std::exception with
    // a message (without the file name) on any damage.
    explicit NanoVdbFileReader(const std::string& path);

    std::vector<std::string> gridNames() const;  // in file order
    // The grid as an OpenVDB grid (float, double, vec3s, vec3d, int32, ...), its name and class
    // kept. Throws where the file cannot hold what it claims or NanoVDB rejects the grid.
    openvdb::GridBase::Ptr readGrid(const std::string& name);

    // True when the path's extension is .nvdb (any case).
    static bool isNanoVdbPath(const std::string& path);

private:
    struct Entry {
        std::string name;
        uint32_t gridType = 0;
        uint16_t codec = 0;
        uint64_t gridSize = 0;  // bytes in memory
        uint64_t fileSize = 0;  // bytes in the file
        uint64_t offset = 0;    // of the grid's block in the file
    };
    std::string mPath;
    uint64_t mFileSize = 0;
    std::vector<Entry> mEntries;
};

}  // namespace nimbus
