// VdbFileReader.cpp: see VdbFileReader.h for why nimbus does not read through openvdb::io::File.
// The order of the reads follows OpenVDB's File::open and File::readGrid (format 222 and later:
// header, file metadata, grid count, descriptors; per grid its compression word, metadata,
// transform, topology, buffers).
#include "VdbFileReader.h"

#include <openvdb/io/File.h>
#include <openvdb/io/io.h>

#include <stdexcept>

namespace nimbus {

namespace {

// Grids that are instances of instances: OpenVDB writes one level; a cycle would recurse forever.
constexpr int kMaxInstanceDepth = 8;

std::string bytes(uint64_t n)
{
    return std::to_string(n) + " bytes";
}


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
    if (!inputHasGridOffsets()) {  // format before 212: read whole by OpenVDB (VdbFileReader.h)
        mStream.close();
        mUnseekable = std::make_unique<openvdb::io::File>(path);
        mUnseekable->open(/*delayLoad=*/false);
        return;
    }
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
    if (mUnseekable) {
        for (auto it = mUnseekable->beginName(); it != mUnseekable->endName(); ++it)
            names.push_back(it.gridName());
        return names;
    }
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
    if (gd)
        word("compression flags");
    const uint32_t entries = word("metadata count");
    if (uint64_t(entries) * 12 > end - pos)
        throw std::runtime_error(what + " claims " + std::to_string(entries) + " metadata entries, more than its " +
                                 bytes(end - pos) + " can hold (truncated or damaged)");
    for (uint32_t i = 0; i < entries; ++i) {
        skip("metadata name");
        skip("metadata type name");
        skip("metadata value");
    }
    if (gd)
        skip("transform type name");
    mStream.seekg(std::streamoff(begin));
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
        checkLengths(uint64_t(gd.getGridPos()), uint64_t(gd.getBlockPos()), &gd);
        if (!gd.isInstance()) {
            // The tree's first word is its buffer count, 1 since OpenVDB 3; for any other value
            // OpenVDB prints a warning of its own to std::cerr (a second line beside nimbus's
            // error) and reads on. Read the metadata and transform to find it, then start over.
            gd.seekToGrid(mStream);
            openvdb::GridBase::Ptr probe = openvdb::GridBase::createGrid(gd.gridType());
            readGridCompression(mStream);
            probe->readMeta(mStream);
            probe->readTransform(mStream);
            int32_t buffers = 0;
            mStream.read(reinterpret_cast<char*>(&buffers), sizeof buffers);
            if (buffers != 1)
                throw std::runtime_error("grid '" + gd.gridName() + "' claims " + std::to_string(buffers) +
                                         " buffers per node, not 1 (damaged)");
        }
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
    if (mUnseekable)
        return mUnseekable->readGrid(name);
    const openvdb::io::GridDescriptor* gd = find(name);
    if (!gd)
        throw std::runtime_error("no grid named '" + name + "'");
    return readGrid(*gd, 0);
}

}  // namespace nimbus
