// VdbFileReader.h: reads grids from a VDB file so that a damaged file costs no more memory than
// its size allows (issue 18, failure 5).
//
// Why not openvdb::io::File: its stream never throws. Garbage after a valid header (random bytes
// from the first few hundred on) reads as node masks with thousands of children, and once the
// stream is at its end every further read fails silently and leaves the counts it was reading as
// they were: RootNode::readTopology then loops over a garbage child count, allocating a 32^3 node
// per pass (11-15 GB before std::bad_alloc, or no answer in a minute). Here the stream throws at
// its end, so a tree can only allocate what the bytes it consumed describe: every node reads its
// masks from the file (a leaf 64 bytes for ~2 KiB of memory, an internal node 1-8 KiB for 33-262
// KiB), a bound of about 32x the file size. The lengths that OpenVDB allocates before reading
// (metadata strings and blobs, up to 4 GiB each) are checked against the bytes left in the file
// first, each metadata value against what OpenVDB reads for its type (a fixed-size type ignores
// its size word; the delayed-load table has counts of its own), and a grid's offsets must lie
// inside the file.
//
// Every compressed block of a grid's tree is checked against what its node holds and the bytes
// left before OpenVDB reads it (BlockCheck in the .cpp): OpenVDB 10's bloscFromStream writes an
// oversized uncompressed block into the node's buffer before it checks the size.
//
// Files without grid offsets (written by io::Stream) are walked grid by grid to find each grid's
// extent. Formats before 222 (OpenVDB before 3.0, 2014) are refused.
#pragma once

#include <openvdb/io/Archive.h>
#include <openvdb/io/GridDescriptor.h>

#include <fstream>
#include <map>
#include <memory>
#include <utility>
#include <string>
#include <vector>

namespace nimbus {

class VdbFileReader : public openvdb::io::Archive {
public:
    // Opens the file and reads its header and grid descriptors. Throws std::exception with a
    // message (without the file name) on any damage.
    explicit VdbFileReader(const std::string& path);

    std::vector<std::string> gridNames() const;  // in file order
    // The grid's metadata, transform and tree; throws where the file cannot hold what it claims.
    openvdb::GridBase::Ptr readGrid(const std::string& name);

private:
    std::string mPath;
    uint64_t mFileSize = 0;
    std::ifstream mStream;
    openvdb::io::StreamMetadata::Ptr mStreamMetadata;
    std::vector<openvdb::io::GridDescriptor> mDescriptors;

    const openvdb::io::GridDescriptor* find(const std::string& name) const;
    openvdb::GridBase::Ptr readGrid(const openvdb::io::GridDescriptor& gd, int depth);
    void checkLengths(uint64_t begin, uint64_t end, const openvdb::io::GridDescriptor* gd);
    void checkMetadataValue(uint64_t at, uint32_t size, const std::string& type, const std::string& entry);
    void checkDelayedLoadTable(uint64_t at, uint32_t size, const std::string& entry);
    std::pair<uint64_t, uint64_t> checkGrid(const openvdb::io::GridDescriptor& gd);
};

}  // namespace nimbus
