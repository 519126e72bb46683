// Procedural.h: procedural volume sources ("cloud", "sphere", "box") built as real OpenVDB
// grids, so that they take the same path to the renderer as a VDB file does (VdbLoad.cpp) and
// can be written out and rendered by any VDB tool for comparisons.
//
// Parameters, defaults and the exact placement of each generator: docs/volumes.md. Every length
// is in metres in the grid's own space; the volume's "transform" places the result in the world.
//
// This header includes no OpenVDB header beyond version.h: they cost ~25 s per translation
// unit. openvdb::FloatGrid is declared here from its template parts (Procedural.cpp checks with a
// static_assert that it is the very same type), so callers that do include OpenVDB get a
// FloatGrid::Ptr and callers that do not pay nothing.
#pragma once

#include "../scene/Scene.h"

#include <openvdb/version.h>  // the versioned namespace only (macros, no OpenVDB types)

#include <cstdint>
#include <memory>
#include <string>

namespace openvdb {
OPENVDB_USE_VERSION_NAMESPACE
namespace OPENVDB_VERSION_NAME {
namespace tree {
template <typename T, uint32_t Log2Dim>
class LeafNode;
template <typename ChildT, uint32_t Log2Dim>
class InternalNode;
template <typename ChildT>
class RootNode;
template <typename RootT>
class Tree;
}  // namespace tree
template <typename TreeT>
class Grid;
}  // namespace OPENVDB_VERSION_NAME
}  // namespace openvdb

namespace nimbus {

class StopFlag;

// openvdb::FloatGrid (Tree4<float, 5, 4, 3>).
using VdbFloatGrid = openvdb::Grid<openvdb::tree::Tree<openvdb::tree::RootNode<
    openvdb::tree::InternalNode<openvdb::tree::InternalNode<openvdb::tree::LeafNode<float, 3>, 4>, 5>>>>;

// Runs source.generator with source.params and returns a FloatGrid named "density"
// (fog volume: background 0, active where the density is non-zero; uniform interiors are
// active tiles). keyPath prefixes error messages and names the source, e.g.
// "scene.json: volumes[0].source": an unknown generator, an unknown parameter, a bad value or a
// grid over ~1.1e9 voxels (a 1024^3 index box) throws InputError "<keyPath>.<param>: <why>".
// A raised `stop` (a cancelled render) ends the generation and throws Cancelled.
std::shared_ptr<VdbFloatGrid> makeProceduralGrid(const VolumeSource& source, const std::string& keyPath,
                                                 const StopFlag* stop = nullptr);

// Writes the grid makeProceduralGrid builds to a .vdb file (one grid, "density"), e.g. to render
// the same cloud with vdb_render. Throws InputError for bad parameters, Error if the file cannot
// be written.
void writeProceduralVdb(const VolumeSource& source, const std::string& path);

}  // namespace nimbus
