// KernelBvh.h: the scene's geometry as the OpenCL path tracer traverses it (kernels/shared/
// geometry.h): a binary BVH built by Embree's BVH builder (rtcBuildBVH) through our own node
// callbacks, flattened depth first into NbBvhNode records, with the primitives reordered so that
// each leaf's are contiguous (docs/geometry.md, "How it is traced").
//
// Why our own tree and not Embree's scene: an OpenCL kernel cannot call Embree, and Embree's
// internal BVH layout is neither stable nor documented; its builder, though, takes callbacks that
// create nodes and leaves in whatever layout the caller wants, so the SAH build is Embree's (binned,
// multi-threaded) and the layout is ours, shared with the kernel and static_asserted.
#pragma once

#include "GeometrySet.h"

#include "../../kernels/shared/geometry.h"

#include <vector>

namespace nimbus {

struct KernelBvh {
    std::vector<NbBvhNode> nodes;   // depth first; nodes[0] is the root; empty without a tree
    std::vector<NbGeomPrim> prims;  // the tree's leaves' primitives, then the infinite planes
    NbGeomScene scene{};            // counts for the kernel
    int depth = 0;                  // the deepest leaf's depth (root: 0)
    double buildSeconds = 0.0;
    size_t memoryBytes() const { return nodes.size() * sizeof(NbBvhNode) + prims.size() * sizeof(NbGeomPrim); }
};

// Builds the tree over every triangle and sphere of the set (flags per primitive, from its
// object) and lists the infinite planes after them. Throws Error where Embree fails.
KernelBvh buildKernelBvh(const GeometrySet& geometry);

}  // namespace nimbus
