// NanoVdbFileReader.cpp: see NanoVdbFileReader.h for why the lengths are checked before
// NanoVDB's I/O reads them. The walk follows nanovdb::io::Segment::read and io::readGrid
// (NanoVDB 32.x, Debian's libnanovdb-dev 10.0.1).
#include "NanoVdbFileReader.h"

// NanoVDB's headers are read with its assertions off (NANOVDB_ASSERT is assert), as the release
// build reads them: a valid grid without leaves that stores a full checksum makes
// validateChecksum's node manager take PtrDiff(null, grid) for level 0, whose assertion aborts a
// build without NDEBUG (fuzz_nvdb, session 31) while the offset it computes is never used with no
// leaves. The reader's own checks come before NanoVDB walks a grid (layoutError).
#ifndef NDEBUG
#define NDEBUG
#define NIMBUS_NANOVDB_NDEBUG
#endif
#include <cassert>
#define NANOVDB_USE_ZIP
#define NANOVDB_USE_BLOSC
#include <nanovdb/util/GridValidator.h>
#include <nanovdb/util/IO.h>
#include <nanovdb/util/NanoToOpenVDB.h>
#ifdef NIMBUS_NANOVDB_NDEBUG
#undef NDEBUG
#undef NIMBUS_NANOVDB_NDEBUG
#include <cassert>  // assert on again for what follows
#endif

#include <algorithm>
#include <cctype>
#include <cstring>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <type_traits>

namespace nimbus {

namespace {

// A compressed grid may decode to at most this many times its bytes in the file (zlib's limit
// is about 1032:1; BLOSC's block headers keep it below this too); beyond it the size is damage.
constexpr uint64_t kMaxCompressionRatio = 4096;

std::string bytes(uint64_t n)
{
    return std::to_string(n) + " bytes";
}

void readAt(std::ifstream& in, uint64_t offset, void* out, uint64_t n, const char* what)
{
    in.seekg(std::streamoff(offset));
    in.read(static_cast<char*>(out), std::streamsize(n));
    if (!in)
        throw std::runtime_error(std::string("the file ends inside ") + what + " (truncated or damaged)");
}

// Where the tree's nodes lie inside the grid's buffer of `size` bytes: the root with its tile
// table, each level's first node and count, every child pointer of the root and the internal
// nodes (GridValidator's own walk, in NanoVDB 32.4, checks the upper nodes where it means the
// leaves). "" when all is inside; the first fault otherwise.
template <class T>
std::string layoutError(const nanovdb::NanoGrid<T>& grid, uint64_t size)
{
    using Tree = nanovdb::NanoTree<T>;
    const auto* base = reinterpret_cast<const uint8_t*>(&grid);
    auto inside = [&](const void* p, uint64_t n) {
        const auto* q = static_cast<const uint8_t*>(p);
        return q >= base && uint64_t(q - base) <= size && n <= size - uint64_t(q - base) &&
               (uint64_t(q - base) % NANOVDB_DATA_ALIGNMENT) == 0;
    };
    if (sizeof(nanovdb::GridData) + sizeof(typename Tree::DataType) > size)
        return "shorter than its grid and tree headers";
    const auto* tree = reinterpret_cast<const typename Tree::DataType*>(&grid.tree());
    // The root's place checked as an integer first: Tree::root() binds a reference to it, which
    // must be aligned (UBSan: fuzz_nvdb's third finding).
    const uint64_t treeAt = uint64_t(reinterpret_cast<const uint8_t*>(tree) - base);
    if (tree->mNodeOffset[3] > size - treeAt ||
        !inside(base + treeAt + tree->mNodeOffset[3], sizeof(typename Tree::RootType::DataType)))
        return "its root node lies outside the grid";
    const auto& root = *reinterpret_cast<const typename Tree::RootType*>(base + treeAt + tree->mNodeOffset[3]);
    if (!inside(&root, root.memUsage()))
        return "its root's tile table lies outside the grid";
    const uint64_t nodeSize[3] = {std::is_same_v<T, nanovdb::FpN> ? 0 : uint64_t(sizeof(typename Tree::LeafNodeType)),
                                  sizeof(typename Tree::Node1), sizeof(typename Tree::Node2)};
    for (int level = 0; level < 3; ++level) {
        const uint64_t count = tree->mNodeCount[level];
        if (count == 0)
            continue;
        if (tree->mNodeOffset[level] > size - treeAt || (nodeSize[level] && count > size / nodeSize[level]) ||
            !inside(base + treeAt + tree->mNodeOffset[level], count * nodeSize[level]))
            return "its level-" + std::to_string(level) + " nodes lie outside the grid";
    }
    // A child `offset` bytes from its parent `from` (a node inside the grid), as a pointer when a
    // node of `bytes` there lies inside the grid; null otherwise. The offset is checked as an
    // integer before any pointer is formed: NanoVDB's own getChild adds it to the parent's address,
    // and a damaged offset overflows the pointer (undefined behaviour; fuzz_nvdb's first finding).
    auto child = [&](const void* from, int64_t offset, uint64_t bytes) -> const uint8_t* {
        const int64_t origin = int64_t(static_cast<const uint8_t*>(from) - base);
        if (offset < -origin || offset > int64_t(size) - origin)
            return nullptr;
        const uint64_t at = uint64_t(origin + offset);
        if (bytes > size - at || at % NANOVDB_DATA_ALIGNMENT != 0)
            return nullptr;
        return base + at;
    };
    using Upper = typename Tree::Node2;
    using Lower = typename Tree::Node1;
    const uint64_t leafBytes =
        std::is_same_v<T, nanovdb::FpN> ? sizeof(typename Tree::LeafNodeType::DataType) : sizeof(typename Tree::LeafNodeType);
    // A tree reaches each node once, so the walk meets at most the header's count of nodes per
    // level. More means children shared between parents: a graph that nanoToOpenVDB would unfold
    // into a tree of up to 32768 x 4096 leaves per upper node, gigabytes from a grid of kilobytes,
    // before any memory check (fuzz_nvdb's out-of-memory finding). The count also ends the walk.
    uint64_t reached[3] = {0, 0, 0};
    auto tooMany = [&](int level) {
        return ++reached[level] > tree->mNodeCount[level];
    };
    auto shared = [](int level) {
        return "more level-" + std::to_string(level) + " nodes are reached than its header counts (children shared)";
    };
    const auto* rootData = root.data();
    for (uint32_t i = 0; i < rootData->mTableSize; ++i) {
        const auto* tile = rootData->tile(i);
        if (!tile->isChild())
            continue;
        const auto* upper = reinterpret_cast<const Upper*>(child(rootData, tile->child, sizeof(Upper)));
        if (!upper)
            return "a root tile's child lies outside the grid";
        if (tooMany(2))
            return shared(2);
        const auto* upperData = upper->data();
        for (auto n = upperData->mChildMask.beginOn(); n; ++n) {
            const auto* lower =
                reinterpret_cast<const Lower*>(child(upperData, upperData->mTable[*n].child, sizeof(Lower)));
            if (!lower)
                return "an upper node's child lies outside the grid";
            if (tooMany(1))
                return shared(1);
            const auto* lowerData = lower->data();
            for (auto m = lowerData->mChildMask.beginOn(); m; ++m) {
                if (!child(lowerData, lowerData->mTable[*m].child, leafBytes))
                    return "a lower node's child lies outside the grid";
                if (tooMany(0))
                    return shared(0);
            }
        }
    }
    return "";
}

// Checks a decoded grid of value type T and converts it; nullptr for another type. Order: the
// header and partial checksum (GridValidator without its node walk), the node layout above, then
// the full checksum when the file stored one (it walks the nodes, hence after the layout).
// `index`: the grid's own mGridIndex (a grid written from a buffer of several keeps its place in
// it, and GridHandle::grid(i) walks the buffer by gridSize until it meets that index).
template <class T>
openvdb::GridBase::Ptr convert(const nanovdb::GridHandle<nanovdb::HostBuffer>& handle, const std::string& name,
                               uint32_t index)
{
    const nanovdb::NanoGrid<T>* grid = handle.template grid<T>(index);
    if (!grid)
        return nullptr;
    auto damaged = [&](const std::string& why) {
        return std::runtime_error("grid '" + name + "' is damaged (" + why + ")");
    };
    if (std::string e = layoutError(*grid, handle.size()); !e.empty())
        throw damaged(e);
    if (std::string e = nanovdb::GridValidator<T>::check(*grid, /*detailed=*/false); !e.empty())
        throw damaged("NanoVDB: " + e);
    if (nanovdb::GridChecksum(grid->checksum()).isFull() && !nanovdb::validateChecksum(*grid, nanovdb::ChecksumMode::Full))
        throw damaged("NanoVDB: Mis-matching checksum");
    return nanovdb::nanoToOpenVDB(*grid);
}

}  // namespace

bool NanoVdbFileReader::isNanoVdbPath(const std::string& path)
{
    if (path.size() < 5)
        return false;
    std::string ext = path.substr(path.size() - 5);
    std::transform(ext.begin(), ext.end(), ext.begin(), [](unsigned char c) { return char(std::tolower(c)); });
    return ext == ".nvdb";
}

NanoVdbFileReader::NanoVdbFileReader(const std::string& path) : mPath(path)
{
    std::ifstream in(path, std::ios_base::in | std::ios_base::binary);
    if (!in)
        throw std::runtime_error("could not open the file");
    in.seekg(0, std::ios_base::end);
    mFileSize = uint64_t(in.tellg());
    uint64_t pos = 0;
    while (pos < mFileSize) {
        nanovdb::io::Header header;
        static_assert(sizeof header == 16, "nanovdb::io::Header is 16 bytes in the file");
        readAt(in, pos, &header, sizeof header, "a segment header");
        pos += sizeof header;
        if (header.magic != NANOVDB_MAGIC_NUMBER)
            throw std::runtime_error(header.magic == nanovdb::io::reverseEndianness(NANOVDB_MAGIC_NUMBER)
                                         ? "a NanoVDB file of the other byte order"
                                         : "not a NanoVDB file (no NanoVDB magic number where a segment begins)");
        if (header.version.getMajor() != NANOVDB_MAJOR_VERSION_NUMBER)
            // (Not Version::c_str(): it returns a malloc'd buffer for the caller to free, which
            // leaked here: fuzz_nvdb's second finding.)
            throw std::runtime_error("written by NanoVDB " + std::to_string(header.version.getMajor()) + "." +
                                     std::to_string(header.version.getMinor()) + "." +
                                     std::to_string(header.version.getPatch()) +
                                     "; this nimbus reads NanoVDB " + std::to_string(NANOVDB_MAJOR_VERSION_NUMBER) +
                                     ".x files (convert it again with that version)");
        if (uint16_t(header.codec) >= uint16_t(nanovdb::io::Codec::END))
            throw std::runtime_error("a segment names the unknown compression codec " +
                                     std::to_string(unsigned(header.codec)) + " (damaged)");
        if (header.gridCount == 0)
            throw std::runtime_error("a segment holds no grids (damaged)");
        std::vector<Entry> segment;
        for (uint32_t i = 0; i < header.gridCount; ++i) {
            nanovdb::io::MetaData meta;
            readAt(in, pos, &meta, sizeof meta, "a grid's metadata");
            pos += sizeof meta;
            if (meta.nameSize == 0 || uint64_t(meta.nameSize) > mFileSize - pos)
                throw std::runtime_error("a grid claims a " + bytes(meta.nameSize) + " name where " +
                                         bytes(mFileSize - pos) + " are left (truncated or damaged)");
            std::string name(meta.nameSize, '\0');
            readAt(in, pos, name.data(), meta.nameSize, "a grid's name");
            pos += meta.nameSize;
            name.resize(std::strlen(name.c_str()));
            Entry e;
            e.name = name;
            e.gridType = uint32_t(meta.gridType);
            e.codec = uint16_t(header.codec);
            e.gridSize = meta.gridSize;
            e.fileSize = meta.fileSize;
            const bool raw = header.codec == nanovdb::io::Codec::NONE;
            if (e.gridSize < sizeof(nanovdb::GridData) + 64 || (raw && e.gridSize != e.fileSize) ||
                (!raw && e.gridSize / kMaxCompressionRatio > e.fileSize))
                throw std::runtime_error("grid '" + name + "' claims " + bytes(e.gridSize) + " in memory from " +
                                         bytes(e.fileSize) + " in the file (damaged)");
            segment.push_back(e);
        }
        for (Entry& e : segment) {
            if (e.fileSize > mFileSize - pos)
                throw std::runtime_error("grid '" + e.name + "' claims " + bytes(e.fileSize) + " where " +
                                         bytes(mFileSize - pos) + " are left (truncated or damaged)");
            e.offset = pos;
            pos += e.fileSize;
            mEntries.push_back(e);
        }
    }
    if (mEntries.empty())
        throw std::runtime_error("an empty file (no NanoVDB segment)");
}

std::vector<std::string> NanoVdbFileReader::gridNames() const
{
    std::vector<std::string> names;
    for (const Entry& e : mEntries)
        names.push_back(e.name);
    return names;
}

openvdb::GridBase::Ptr NanoVdbFileReader::readGrid(const std::string& name)
{
    const Entry* e = nullptr;
    for (const Entry& c : mEntries)
        if (c.name == name) {
            e = &c;
            break;
        }
    if (!e)
        throw std::runtime_error("no grid named '" + name + "'");

    // The grid's block, bounded by the file (constructor), then its compressed chunks' sizes
    // checked against it before NanoVDB allocates them (io::Internal::read).
    std::string block(e->fileSize, '\0');
    {
        std::ifstream in(mPath, std::ios_base::in | std::ios_base::binary);
        if (!in)
            throw std::runtime_error("could not open the file again");
        readAt(in, e->offset, block.data(), e->fileSize, ("grid '" + name + "'").c_str());
    }
    const auto codec = nanovdb::io::Codec(e->codec);
    if (codec != nanovdb::io::Codec::NONE) {
        uint64_t at = 0, decoded = 0;
        do {
            uint64_t size = 0;
            if (block.size() - at < sizeof size)
                throw std::runtime_error("grid '" + name + "': a compressed chunk's size lies past its block (damaged)");
            std::memcpy(&size, block.data() + at, sizeof size);
            at += sizeof size;
            if (size > block.size() - at)
                throw std::runtime_error("grid '" + name + "': a compressed chunk claims " + bytes(size) + " where " +
                                         bytes(block.size() - at) + " are left (damaged)");
            at += size;
            decoded += codec == nanovdb::io::Codec::ZIP ? e->gridSize
                                                        : std::min<uint64_t>(nanovdb::io::Internal::MAX_SIZE,
                                                                             e->gridSize - decoded);
        } while (decoded < e->gridSize);
    }
    nanovdb::GridHandle<nanovdb::HostBuffer> handle(nanovdb::HostBuffer::create(e->gridSize));
    std::istringstream is(block);
    nanovdb::io::Internal::read(is, handle, codec);

    const auto* data = reinterpret_cast<const nanovdb::GridData*>(handle.data());
    if (!data || data->mGridSize != e->gridSize)
        throw std::runtime_error("grid '" + name + "' decodes to a grid whose size differs from its metadata (damaged)");
    // The buffer holds this one grid: GridHandle::grid(i) walks from it by gridSize to the grid
    // whose index is i, past the buffer for an index the grid does not have (UBSan: fuzz_nvdb,
    // session 31). Asked for its own index, it returns it without a step.
    const uint32_t index = data->mGridIndex;
    if (data->mGridCount == 0 || index >= data->mGridCount)
        throw std::runtime_error("grid '" + name + "' says it is grid " + std::to_string(index) + " of " +
                                 std::to_string(data->mGridCount) + " in its buffer (damaged)");
    openvdb::GridBase::Ptr grid;
    if (!(grid = convert<float>(handle, name, index)) && !(grid = convert<double>(handle, name, index)) &&
        !(grid = convert<nanovdb::Fp4>(handle, name, index)) && !(grid = convert<nanovdb::Fp8>(handle, name, index)) &&
        !(grid = convert<nanovdb::Fp16>(handle, name, index)) && !(grid = convert<nanovdb::FpN>(handle, name, index)) &&
        !(grid = convert<nanovdb::Vec3f>(handle, name, index)) && !(grid = convert<nanovdb::Vec3d>(handle, name, index)) &&
        !(grid = convert<int32_t>(handle, name, index)) && !(grid = convert<int64_t>(handle, name, index)) &&
        !(grid = convert<bool>(handle, name, index)) && !(grid = convert<nanovdb::ValueMask>(handle, name, index)))
        throw std::runtime_error("grid '" + name + "' has the NanoVDB type " +
                                 nanovdb::toStr(nanovdb::GridType(std::min<uint32_t>(
                                     e->gridType, uint32_t(nanovdb::GridType::End)))) +
                                 "; a float grid (or a vec3 grid for Cd and vel) is needed");
    return grid;
}

}  // namespace nimbus
