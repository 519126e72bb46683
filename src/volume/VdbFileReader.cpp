// VdbFileReader.cpp: see VdbFileReader.h for why nimbus does not read through openvdb::io::File.
// The order of the reads follows OpenVDB's File::open and File::readGrid (format 222 and later:
// header, file metadata, grid count, descriptors; per grid its compression word, metadata,
// transform, topology, buffers).
#include "VdbFileReader.h"

#include <openvdb/io/Compression.h>
#include <openvdb/io/DelayedLoadMetadata.h>
#include <openvdb/io/File.h>
#include <openvdb/io/io.h>
#include <openvdb/points/StreamCompression.h>
#include <openvdb/openvdb.h>

#include <blosc.h>
#include <zlib.h>

#include <algorithm>
#include <cstdio>
#include <stdexcept>
#include <type_traits>
#include <vector>

namespace nimbus {

namespace {

// Grids that are instances of instances: OpenVDB writes one level; a cycle would recurse forever.
constexpr int kMaxInstanceDepth = 8;

std::string bytes(uint64_t n)
{
    return std::to_string(n) + " bytes";
}


// Blosc's header (blosc.h), the 16 bytes at the stream's position: version, flags and type size,
// then the uncompressed size, the block size and the compressed size, each 32 bits little-endian.
struct BloscSizes {
    uint32_t unpacked, packed;
};

BloscSizes readBloscHeader(std::istream& is)
{
    unsigned char header[16];
    is.read(reinterpret_cast<char*>(header), sizeof header);
    auto word = [&](int i) {
        return uint32_t(header[i]) | uint32_t(header[i + 1]) << 8 | uint32_t(header[i + 2]) << 16 |
               uint32_t(header[i + 3]) << 24;
    };
    return {word(4), word(12)};
}

// The grid types whose trees BlockCheck walks: every type openvdb::initialize() registers but
// the point grids (their leaves read attribute arrays of their own layout; nimbus reads none).
using CheckedGridTypes = openvdb::TypeList<openvdb::FloatGrid, openvdb::DoubleGrid, openvdb::Int32Grid,
                                           openvdb::Int64Grid, openvdb::Vec3IGrid, openvdb::Vec3SGrid,
                                           openvdb::Vec3DGrid, openvdb::BoolGrid, openvdb::MaskGrid>;

// Walks a grid's topology and leaf buffers as OpenVDB 10 reads them (Tree::readTopology,
// RootNode/InternalNode/LeafNode::readTopology and readBuffers, io::readCompressedValues,
// io::readData) without allocating a node, and checks every block that io::bloscFromStream or
// io::unzipFromStream would read against what the node holds and the bytes left, before OpenVDB
// reads it. bloscFromStream reads an uncompressed block (a negative size) into the node's buffer
// before it compares the size with the buffer's (a damaged file overflows the heap), allocates a
// compressed block's stated size, and lets Blosc read as far as the block's own header says;
// unzipFromStream allocates the stated size. Format 222 (OpenVDB 3, 2014) and later.
class BlockCheck {
public:
    BlockCheck(std::istream& is, uint32_t compression, bool half, std::string what)
        : mIs(is), mCompression(compression), mHalf(half), mWhat(std::move(what))
    {
    }

    // Returns where the tree's data ends. blocks: the grid's block offset, or 0 where the file
    // has none (written by io::Stream): the buffers then follow the topology (set to where).
    template <class TreeT>
    uint64_t tree(uint64_t topology, uint64_t& blocks, uint64_t end)
    {
        using ValueT = typename TreeT::ValueType;
        using RootT = typename TreeT::RootNodeType;
        std::vector<openvdb::Index32> leafActive;  // each leaf's active voxels, in file order
        start(topology, blocks ? blocks : end, "topology");
        skip(4, "buffer count");  // checked by readGrid
        value<ValueT>("the background");
        const uint32_t tiles = read<uint32_t>("root tile count");
        const uint32_t children = read<uint32_t>("root child count");
        // Each tile: its origin (3 int32), its value, its active flag, which RootNode::readTopology
        // reads straight into a bool: a byte other than 0 or 1 is undefined behaviour there.
        need(uint64_t(tiles) * (12 + sizeof(ValueT) + 1), "root tiles");
        for (uint32_t i = 0; i < tiles; ++i) {
            skip(12, "root tile origin");
            value<ValueT>("root tile " + std::to_string(i) + "'s value");
            boolByte("root tile " + std::to_string(i) + "'s active flag");
        }
        for (uint32_t i = 0; i < children; ++i) {
            skip(12, "root child origin");
            node<typename RootT::ChildNodeType>(leafActive);
        }
        // OpenVDB reads the buffers from where the topology ends, not from the block offset.
        if (!blocks)
            blocks = mPos;
        else if (mPos != blocks)
            damaged("the topology ends short of the grid's block offset " + std::to_string(blocks));
        using LeafT = typename TreeT::LeafNodeType;
        start(blocks, end, "leaf buffers");
        for (const openvdb::Index32 active : leafActive) {
            if constexpr (std::is_same_v<typename LeafT::BuildType, openvdb::ValueMask>) {
                skip(LeafT::NodeMaskType::memUsage() + 12, "mask leaf");  // its mask, its origin
            } else if constexpr (std::is_same_v<ValueT, bool>) {
                skip(2 * LeafT::NodeMaskType::memUsage() + 12, "bool leaf");  // and its values' mask
            } else {
                skip(LeafT::NodeMaskType::memUsage(), "leaf value mask");
                values<ValueT>(LeafT::SIZE, active, LeafT::NodeMaskType::memUsage());
            }
        }
        return mPos;
    }

private:
    std::istream& mIs;
    const uint32_t mCompression;
    const bool mHalf;
    const std::string mWhat;
    uint64_t mPos = 0, mEnd = 0;
    const char* mSection = "";

    void start(uint64_t begin, uint64_t end, const char* section)
    {
        mPos = begin;
        mEnd = end;
        mSection = section;
        mIs.seekg(std::streamoff(begin));
    }

    [[noreturn]] void damaged(const std::string& problem) const
    {
        throw std::runtime_error(mWhat + ": " + problem + " at byte " + std::to_string(mPos) + " of its " + mSection +
                                 " (damaged)");
    }

    void need(uint64_t n, const char* field) const
    {
        if (n > mEnd - mPos)
            damaged(std::string("its ") + field + " (" + bytes(n) + ") runs past the " + bytes(mEnd - mPos) +
                    " left");
    }

    void skip(uint64_t n, const char* field)
    {
        need(n, field);
        mPos += n;
        mIs.seekg(std::streamoff(mPos));
    }

    template <class T>
    T read(const char* field)
    {
        need(sizeof(T), field);
        T value{};
        mIs.read(reinterpret_cast<char*>(&value), sizeof value);
        mPos += sizeof value;
        return value;
    }

    // A byte OpenVDB reads straight into a bool (a tile's active flag; every value of a bool or
    // mask tree): one other than 0 or 1 is undefined behaviour there (UBSan: "not a valid value
    // for type 'bool'"), so it is refused first.
    void boolByte(const std::string& what)
    {
        const uint8_t b = read<uint8_t>("bool");
        if (b > 1) {
            mPos -= 1;  // name the byte itself
            char hex[8];
            std::snprintf(hex, sizeof hex, "0x%02X", unsigned(b));
            damaged(what + " is byte " + hex + ", not 0 or 1");
        }
    }

    // One value of the tree's type as OpenVDB reads it: a bool's byte checked, others skipped.
    template <class ValueT>
    void value(const std::string& what)
    {
        if constexpr (std::is_same_v<ValueT, bool>)
            boolByte(what);
        else
            skip(sizeof(ValueT), "value");
    }

    template <class NodeT>
    void node(std::vector<openvdb::Index32>& leafActive)
    {
        using MaskT = typename NodeT::NodeMaskType;
        need(MaskT::memUsage(), "node mask");
        MaskT mask;
        mask.load(mIs);
        mPos += MaskT::memUsage();
        if constexpr (NodeT::LEVEL == 0) {
            leafActive.push_back(mask.countOn());  // the value mask (a mask leaf's values)
        } else {
            need(MaskT::memUsage(), "node value mask");
            MaskT valueMask;
            valueMask.load(mIs);
            mPos += MaskT::memUsage();
            values<typename NodeT::ValueType>(NodeT::NUM_VALUES, valueMask.countOn(), MaskT::memUsage());
            for (auto it = mask.beginOn(); it; ++it)  // the child mask
                node<typename NodeT::ChildNodeType>(leafActive);
        }
    }

    // io::readCompressedValues: a node's `count` values, `active` of them active.
    template <class ValueT>
    void values(openvdb::Index count, openvdb::Index active, uint64_t maskBytes)
    {
        namespace io = openvdb::io;
        const int8_t metadata = read<int8_t>("compression metadata");
        if (metadata == io::NO_MASK_AND_ONE_INACTIVE_VAL || metadata == io::MASK_AND_ONE_INACTIVE_VAL ||
            metadata == io::MASK_AND_TWO_INACTIVE_VALS)
            for (int k = 0; k < (metadata == io::MASK_AND_TWO_INACTIVE_VALS ? 2 : 1); ++k)
                value<ValueT>("an inactive value");
        if (metadata == io::MASK_AND_NO_INACTIVE_VALS || metadata == io::MASK_AND_ONE_INACTIVE_VAL ||
            metadata == io::MASK_AND_TWO_INACTIVE_VALS)
            skip(maskBytes, "selection mask");
        const bool maskCompressed = mCompression & io::COMPRESS_ACTIVE_MASK;
        const openvdb::Index n = maskCompressed && metadata != io::NO_MASK_AND_ALL_VALS ? active : count;
        if constexpr (bool(io::RealToHalf<ValueT>::isReal)) {
            if (mHalf) {
                if (n > 0)  // io::HalfReader reads nothing for no values
                    block(uint64_t(n) * sizeof(typename io::RealToHalf<ValueT>::HalfT));
                return;
            }
        }
        block(uint64_t(n) * sizeof(ValueT), std::is_same_v<ValueT, bool>);
    }

    // io::readData: `size` bytes, stored as the grid's compression says. bools: the values are
    // bools, each byte checked, where a block is compressed after unpacking it as OpenVDB will
    // (its sizes checked first, so the unpacking writes no more than `size` bytes).
    void block(uint64_t size, bool bools = false)
    {
        namespace io = openvdb::io;
        if (!(mCompression & (io::COMPRESS_BLOSC | io::COMPRESS_ZIP))) {
            rawValues(size, bools, "values");
            return;
        }
        const bool blosc = mCompression & io::COMPRESS_BLOSC;
        const uint64_t at = mPos;
        const int64_t stated = read<int64_t>("block size");
        if (stated <= 0) {  // stored uncompressed
            const uint64_t length = uint64_t(0) - uint64_t(stated);
            if (length != size) {
                mPos = at;
                damaged("an uncompressed block of " + bytes(length) + " where its node holds " + bytes(size));
            }
            rawValues(length, bools, "uncompressed block");
            return;
        }
        need(uint64_t(stated), "compressed block");
        if (blosc) {
            if (stated < 16) {
                mPos = at;
                damaged("a Blosc block of " + bytes(uint64_t(stated)) + ", shorter than its header");
            }
            const auto [unpacked, packed] = readBloscHeader(mIs);
            if (unpacked != size || packed < 16 || packed > uint64_t(stated)) {
                mPos = at;
                damaged("a Blosc block of " + bytes(uint64_t(stated)) + " claims " + bytes(packed) +
                        " compressed to " + bytes(unpacked) + " where its node holds " + bytes(size));
            }
        }
        mPos = at + 8;
        if (bools)
            packedBools(uint64_t(stated), size, blosc);
        skip(uint64_t(stated), "compressed block");
    }

    // `n` bytes of values stored as they are: skipped, or each checked where they are bools.
    void rawValues(uint64_t n, bool bools, const char* field)
    {
        if (!bools) {
            skip(n, field);
            return;
        }
        need(n, field);
        for (uint64_t k = 0; k < n; ++k)
            boolByte("a node value");
    }

    // A compressed block of `size` bools at mPos, `stated` bytes long: unpacked (zlib's
    // uncompress for ZIP, blosc_decompress for Blosc), then each byte checked. The stream is left
    // where it was.
    void packedBools(uint64_t stated, uint64_t size, bool blosc)
    {
        // Neither codec's output outgrows its input by more than this (zlib's compressBound: 0.1%
        // and 13 bytes; Blosc's header: 16): the buffer below is no larger than the node's values.
        if (stated > size + size / 64 + 64)
            damaged("a compressed block of " + bytes(stated) + " for the " + bytes(size) + " its node holds");
        std::vector<unsigned char> packed(stated), values(size);
        mIs.seekg(std::streamoff(mPos));
        mIs.read(reinterpret_cast<char*>(packed.data()), std::streamsize(stated));
        mIs.seekg(std::streamoff(mPos));
        bool unpacked;
        if (blosc) {
            unpacked = blosc_decompress(packed.data(), values.data(), size) == int(size);
        } else {
            uLongf length = uLongf(size);
            unpacked = uncompress(values.data(), &length, packed.data(), uLong(stated)) == Z_OK && length == size;
        }
        if (!unpacked)
            damaged(std::string("a ") + (blosc ? "Blosc" : "ZIP") + " block of " + bytes(stated) +
                    " that does not unpack to the " + bytes(size) + " its node holds");
        for (uint64_t k = 0; k < size; ++k)
            if (values[k] > 1) {
                char hex[8];
                std::snprintf(hex, sizeof hex, "0x%02X", unsigned(values[k]));
                damaged("a node value (" + std::to_string(k) + " of " + std::to_string(size) +
                        " in a compressed block) is byte " + hex + ", not 0 or 1");
            }
    }
};

}  // namespace

VdbFileReader::VdbFileReader(const std::string& path) : mPath(path)
{
    mStream.open(path, std::ios_base::in | std::ios_base::binary);
    if (!mStream)
        throw std::runtime_error("could not open the file");
    mStream.seekg(0, std::ios_base::end);
    mFileSize = uint64_t(mStream.tellg());
    mStream.seekg(0);
    // A read past the end throws instead of leaving its target as it was (VdbFileReader.h).
    mStream.exceptions(std::ios_base::failbit | std::ios_base::badbit);
    try {
        readHeader(mStream);
    } catch (const std::ios_base::failure&) {
        throw std::runtime_error("not a VDB file (shorter than a VDB header)");
    }
    // The formats before 222 (OpenVDB before 3.0, 2014) lay out metadata, transforms and trees
    // differently; the checks here follow 222 and later, and a damaged old header reached
    // OpenVDB's unchecked metadata reads (1 GB, 27 s under ASan: fuzz_vdb). Not read.
    if (fileVersion() < openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION)
        throw std::runtime_error("VDB format " + std::to_string(fileVersion()) +
                                 " (OpenVDB before 3.0) is not read; save the file again with a current OpenVDB");
    // Without grid offsets: written by io::Stream (each grid right after its descriptor).
    // OpenVDB's own reader (io::File) trusts every length of such a file; a damaged one allocated
    // 4.5 GB before it failed (fuzz_vdb). Walked here grid by grid instead.
    const bool streamed = !inputHasGridOffsets();
    mStreamMetadata = std::make_shared<openvdb::io::StreamMetadata>();
    mStreamMetadata->setSeekable(true);
    openvdb::io::setStreamMetadataPtr(mStream, mStreamMetadata, /*transfer=*/false);
    setFormatVersion(mStream);
    setLibraryVersion(mStream);
    setDataCompression(mStream);
    try {
        checkLengths(uint64_t(mStream.tellg()), mFileSize, nullptr);
        openvdb::MetaMap fileMeta;
        fileMeta.readMeta(mStream);
        const int32_t count = readGridCount(mStream);
        // A descriptor holds at least three length words and three offsets.
        if (count < 0 || uint64_t(count) * 36 > mFileSize)
            throw std::runtime_error("claims " + std::to_string(count) + " grids, more than its " +
                                     bytes(mFileSize) + " can hold");
        for (int32_t i = 0; i < count; ++i) {
            // Name, type and instance parent: three strings whose lengths OpenVDB allocates.
            const uint64_t at = uint64_t(mStream.tellg());
            uint64_t pos = at;
            const int strings = fileVersion() >= openvdb::OPENVDB_FILE_VERSION_GRID_INSTANCING ? 3 : 2;
            for (int s = 0; s < strings; ++s) {
                uint32_t length = 0;
                mStream.seekg(std::streamoff(pos));
                mStream.read(reinterpret_cast<char*>(&length), sizeof length);
                pos += sizeof length + uint64_t(length);
                if (pos > mFileSize)
                    throw std::runtime_error("a grid descriptor claims a " + bytes(length) +
                                             " name, beyond the end of the " + bytes(mFileSize) + " file");
            }
            mStream.seekg(std::streamoff(at));
            openvdb::io::GridDescriptor gd;
            gd.read(mStream);
            if (streamed) {  // the grid follows; its end is where its tree says
                gd.setGridPos(mStream.tellg());
                gd.setBlockPos(0);
                gd.setEndPos(0);
                const auto [blocks, end] = checkGrid(gd);
                gd.setBlockPos(int64_t(blocks));
                gd.setEndPos(int64_t(end));
            }
            const int64_t grid = gd.getGridPos(), block = gd.getBlockPos(), end = gd.getEndPos();
            if (!(grid > 0 && grid <= block && block <= end && uint64_t(end) <= mFileSize))
                throw std::runtime_error("grid '" + gd.gridName() + "' has offsets " + std::to_string(grid) + ", " +
                                         std::to_string(block) + ", " + std::to_string(end) +
                                         " that do not lie in order inside the " + bytes(mFileSize) + " file");
            mDescriptors.push_back(gd);
            gd.seekToEnd(mStream);
        }
    } catch (const std::ios_base::failure&) {
        throw std::runtime_error("the file ends inside its header or grid descriptors (truncated or damaged)");
    }
}

std::vector<std::string> VdbFileReader::gridNames() const
{
    std::vector<std::string> names;
    for (const auto& gd : mDescriptors)
        names.push_back(gd.gridName());
    return names;
}

// By grid name, else by unique name ("name[1]" for a second grid of the same name), as
// openvdb::io::File finds them.
const openvdb::io::GridDescriptor* VdbFileReader::find(const std::string& name) const
{
    for (const auto& gd : mDescriptors)
        if (gd.gridName() == name)
            return &gd;
    const std::string unique = openvdb::io::GridDescriptor::stringAsUniqueName(name);
    for (const auto& gd : mDescriptors)
        if (gd.uniqueName() == unique)
            return &gd;
    return nullptr;
}

// OpenVDB reads a metadata value by its type, not by the size word before it (MetaMap::readMeta,
// Metadata.h): a registered fixed-size type reads its own size whatever the word says, a string
// or an unknown type the word's bytes, and the delayed-load table (io/DelayedLoadMetadata.cc)
// walks counts of its own and allocates them first. Each must agree with the `size` bytes at
// `at`, or the reads after it fall out of step with the checks here (a fuzzed 'int32' of 12
// bytes made OpenVDB take a name's characters for a 1.8 GB string length).
void VdbFileReader::checkMetadataValue(uint64_t at, uint32_t size, const std::string& type,
                                       const std::string& entry)
{
    if (type == openvdb::io::DelayedLoadMetadata::staticTypeName()) {
        checkDelayedLoadTable(at, size, entry);
        return;
    }
    if (!openvdb::Metadata::isRegisteredType(type) || type == openvdb::StringMetadata::staticTypeName())
        return;  // read as the word says
    const uint32_t holds = openvdb::Metadata::createMetadata(type)->size();
    if (size != holds)
        throw std::runtime_error(entry + " claims " + bytes(size) + "; the type holds " + bytes(holds) +
                                 " (damaged)");
}

// The delayed-load table OpenVDB writes beside a grid's metadata (io/DelayedLoadMetadata.cc): a
// leaf count, then a per-leaf mask of int8 and optionally per-leaf sizes of int64, each either raw
// (a zero word, then count values) or one Blosc block (its byte count, then the block; Blosc's
// header states the bytes it unpacks to, which OpenVDB reserves: the array's, or 128 for a shorter
// array, which OpenVDB pads before packing). The sizes' word is 0xffffffff
// where there are none. OpenVDB allocates each count and block before it reads it, and reads on
// past `size` where the table claims more.
void VdbFileReader::checkDelayedLoadTable(uint64_t at, uint32_t size, const std::string& entry)
{
    if (size == 0)
        return;  // an empty table: OpenVDB reads nothing
    uint64_t pos = at;
    const uint64_t end = at + size;
    auto word = [&](const char* field) {
        if (pos + 4 > end)
            throw std::runtime_error(entry + ": its " + field + " lies beyond its " + bytes(size) + " (damaged)");
        uint32_t value = 0;
        mStream.seekg(std::streamoff(pos));
        mStream.read(reinterpret_cast<char*>(&value), sizeof value);
        pos += 4;
        return value;
    };
    const uint32_t count = word("leaf count");
    // Each leaf of the tree is at least its 64-byte value mask in the file.
    if (uint64_t(count) * 64 > mFileSize)
        throw std::runtime_error(entry + " claims " + std::to_string(count) + " leaves, more than the " +
                                 bytes(mFileSize) + " file can hold (damaged)");
    auto array = [&](uint32_t stored, uint64_t valueSize, const char* field) {
        const uint64_t unpacked = uint64_t(count) * valueSize;
        if (stored == 0) {  // raw
            if (unpacked > end - pos)
                throw std::runtime_error(entry + ": its " + field + " (" + bytes(unpacked) + ") runs past its " +
                                         bytes(size) + " (damaged)");
            pos += unpacked;
            return;
        }
        if (stored < 16 || stored > end - pos)
            throw std::runtime_error(entry + ": its " + field + " is a Blosc block of " + bytes(stored) + " where " +
                                     bytes(end - pos) + " are left (damaged)");
        mStream.seekg(std::streamoff(pos));
        // OpenVDB pads an array shorter than 128 bytes to 128 before Blosc packs it
        // (points/StreamCompression.h, BLOSC_PAD_BYTES).
        const uint64_t padded = std::max<uint64_t>(unpacked, openvdb::compression::BLOSC_PAD_BYTES);
        const auto [claims, packed] = readBloscHeader(mStream);
        if (claims != padded || packed < 16 || packed > stored)
            throw std::runtime_error(entry + ": its " + field + " is a Blosc block claiming " + bytes(packed) +
                                     " compressed to " + bytes(claims) + " where " + std::to_string(count) +
                                     " leaves take " + bytes(padded) + " (damaged)");
        pos += stored;
    };
    array(word("mask block size"), sizeof(openvdb::io::DelayedLoadMetadata::MaskType), "leaf mask");
    const uint32_t sizes = word("size block size");
    if (sizes != 0xffffffffu)
        array(sizes, sizeof(openvdb::io::DelayedLoadMetadata::CompressedSizeType), "leaf sizes");
}

// The metadata OpenVDB reads from `begin` (a grid's, after its compression word, when gd is
// given; the file's otherwise) and a grid's transform type: each length is checked against the
// bytes before `end`, where OpenVDB would allocate it first and find the file too short after.
void VdbFileReader::checkLengths(uint64_t begin, uint64_t end, const openvdb::io::GridDescriptor* gd)
{
    if (fileVersion() < openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION)
        return;  // older layouts: the throwing stream still bounds the tree
    const std::string what = gd ? "grid '" + gd->gridName() + "'" : std::string("the file's metadata");
    uint64_t pos = begin;
    auto word = [&](const char* field) {
        if (pos + 4 > end)
            throw std::runtime_error(what + ": its " + field + " lies beyond the " + bytes(end - begin) +
                                     " it has (truncated or damaged)");
        uint32_t value = 0;
        mStream.seekg(std::streamoff(pos));
        mStream.read(reinterpret_cast<char*>(&value), sizeof value);
        pos += 4;
        return value;
    };
    auto skip = [&](const char* field) {
        const uint32_t length = word(field);
        if (uint64_t(length) > end - pos)
            throw std::runtime_error(what + " claims a " + bytes(length) + " " + field + " where " +
                                     bytes(end - pos) + " are left (truncated or damaged)");
        pos += length;
    };
    auto text = [&](const char* field) {
        const uint32_t length = word(field);
        if (uint64_t(length) > end - pos)
            throw std::runtime_error(what + " claims a " + bytes(length) + " " + field + " where " +
                                     bytes(end - pos) + " are left (truncated or damaged)");
        std::string value(length, '\0');
        mStream.seekg(std::streamoff(pos));
        mStream.read(value.data(), std::streamsize(length));
        pos += length;
        return value;
    };
    if (gd)
        word("compression flags");
    const uint32_t entries = word("metadata count");
    if (uint64_t(entries) * 12 > end - pos)
        throw std::runtime_error(what + " claims " + std::to_string(entries) + " metadata entries, more than its " +
                                 bytes(end - pos) + " can hold (truncated or damaged)");
    for (uint32_t i = 0; i < entries; ++i) {
        const std::string name = text("metadata name");
        const std::string type = text("metadata type name");
        const uint32_t size = word("metadata value size");
        if (uint64_t(size) > end - pos)
            throw std::runtime_error(what + " claims a " + bytes(size) + " metadata value where " + bytes(end - pos) +
                                     " are left (truncated or damaged)");
        const std::string entry = what + ": its metadata '" + name + "' of type '" + type + "'";
        checkMetadataValue(pos, size, type, entry);
        pos += size;
    }
    if (gd)
        skip("transform type name");
    mStream.seekg(std::streamoff(begin));
}

// Checks the grid whose data begins at gd's grid offset (VdbFileReader.h): its metadata and
// transform lengths, its buffer count and every compressed block of its tree (BlockCheck).
// Returns where the grid's topology and data end (its block and end offsets). For a file without
// offsets (io::Stream), gd's block and end offsets are 0: its data then runs as its tree says,
// and at most to the end of the file.
std::pair<uint64_t, uint64_t> VdbFileReader::checkGrid(const openvdb::io::GridDescriptor& gd)
{
    const std::string what = "grid '" + gd.gridName() + "'";
    if (!openvdb::GridBase::isRegistered(gd.gridType()))
        throw std::runtime_error(what + " has the unknown type '" + gd.gridType() + "'");
    uint64_t blocks = uint64_t(gd.getBlockPos());
    const uint64_t end = gd.getEndPos() ? uint64_t(gd.getEndPos()) : mFileSize;
    checkLengths(uint64_t(gd.getGridPos()), blocks ? blocks : end, &gd);
    // Read the metadata and transform to find the tree, then start over.
    gd.seekToGrid(mStream);
    openvdb::GridBase::Ptr probe = openvdb::GridBase::createGrid(gd.gridType());
    readGridCompression(mStream);
    probe->readMeta(mStream);
    probe->readTransform(mStream);
    const uint64_t topology = uint64_t(mStream.tellg());
    if (gd.isInstance())
        return {topology, topology};  // the tree is its parent's
    // The tree's first word is its buffer count, 1 since OpenVDB 3; for any other value OpenVDB
    // prints a warning of its own to std::cerr (a second line beside nimbus's error) and reads on.
    int32_t buffers = 0;
    mStream.read(reinterpret_cast<char*>(&buffers), sizeof buffers);
    if (buffers != 1)
        throw std::runtime_error(what + " claims " + std::to_string(buffers) + " buffers per node, not 1 (damaged)");
    // Every compressed block checked before OpenVDB reads one (BlockCheck).
    const uint32_t compression = openvdb::io::getDataCompression(mStream);
    if (fileVersion() < openvdb::OPENVDB_FILE_VERSION_NODE_MASK_COMPRESSION) {
        if (compression & openvdb::io::COMPRESS_BLOSC)
            throw std::runtime_error(what + " claims Blosc compression, which its format version " +
                                     std::to_string(fileVersion()) + " predates (damaged)");
        return {blocks, end};
    }
    BlockCheck check(mStream, compression, gd.saveFloatAsHalf(), what);
    uint64_t dataEnd = 0;
    const bool walked = probe->apply<CheckedGridTypes>([&](auto& typed) {
        using TreeT = typename std::decay_t<decltype(typed)>::TreeType;
        dataEnd = check.tree<TreeT>(topology, blocks, end);
    });
    if (!walked)
        throw std::runtime_error(what + " has the type '" + gd.gridType() + "', which nimbus does not read (points?)");
    return {blocks, dataEnd};
}

openvdb::GridBase::Ptr VdbFileReader::readGrid(const openvdb::io::GridDescriptor& gd, int depth)
{
    if (depth > kMaxInstanceDepth)
        throw std::runtime_error("grid '" + gd.gridName() + "': instances nested deeper than " +
                                 std::to_string(kMaxInstanceDepth) + " (a cycle?)");
    if (!openvdb::GridBase::isRegistered(gd.gridType()))
        throw std::runtime_error("grid '" + gd.gridName() + "' has the unknown type '" + gd.gridType() + "'");
    openvdb::GridBase::Ptr grid = openvdb::GridBase::createGrid(gd.gridType());
    grid->setSaveFloatAsHalf(gd.saveFloatAsHalf());
    try {
        checkGrid(gd);
        gd.seekToGrid(mStream);
        Archive::readGrid(grid, gd, mStream);
    } catch (const std::ios_base::failure&) {
        throw std::runtime_error("grid '" + gd.gridName() + "': the file ends before the data its tree describes (" +
                                 bytes(mFileSize) + "; truncated or damaged)");
    }
    if (gd.isInstance()) {
        const std::string parentName = openvdb::io::GridDescriptor::nameAsString(gd.instanceParentName());
        const openvdb::io::GridDescriptor* parent = find(parentName);
        if (!parent)
            throw std::runtime_error("grid '" + gd.gridName() + "' is an instance of the missing grid '" +
                                     parentName + "'");
        grid->setTree(readGrid(*parent, depth + 1)->baseTreePtr());
    }
    return grid;
}

openvdb::GridBase::Ptr VdbFileReader::readGrid(const std::string& name)
{
    const openvdb::io::GridDescriptor* gd = find(name);
    if (!gd)
        throw std::runtime_error("no grid named '" + name + "'");
    return readGrid(*gd, 0);
}

}  // namespace nimbus
