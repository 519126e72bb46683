// ActiveResample.h: the walk over the active region only must give every output voxel's trilinear
// sample (walked over the whole box, the reference), and every value OpenVDB's own resampler
// (resampleToMatch<BoxSampler>, tools/GridTransformer.h) gives, on lattices finer, rotated,
// sheared, mirrored and slightly coarser than the input's, for scattered voxels, filled blocks and
// active tiles; and the same result on one thread as on many.
#include "volume/ActiveResample.h"

#include <gtest/gtest.h>

#include <openvdb/openvdb.h>
#include <openvdb/tools/GridTransformer.h>

#include <tbb/task_arena.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <string>

using namespace nimbus;
using openvdb::Coord;
using openvdb::CoordBBox;

namespace {

openvdb::math::Transform::Ptr affine(const openvdb::Mat4d& m)
{
    return openvdb::math::Transform::createLinearTransform(m);
}

// Scattered voxels, an 8^3 block off the leaf lattice, a filled box across leaves and an active
// 8^3 tile, with inactive voxels holding the background (as VdbLoad's dropInactiveNodes leaves a
// role grid). Values from `value(i)`.
template <class GridT, class Value>
typename GridT::Ptr sparseGrid(double voxel, Value value, bool withTile = true)
{
    typename GridT::Ptr grid = GridT::create(value(-1));
    grid->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
    std::mt19937 rng(7);
    std::uniform_int_distribution<int> at(-20, 20);
    for (int i = 0; i < 200; ++i)
        grid->tree().setValueOn(Coord(at(rng), at(rng), at(rng)), value(i));
    int i = 0;
    for (const CoordBBox& box : {CoordBBox(Coord(3, -5, 10), Coord(10, 2, 17)), CoordBBox(Coord(-22), Coord(-13))})
        for (auto ijk = box.begin(); ijk; ++ijk)
            grid->tree().setValueOn(*ijk, value(i++));
    if (withTile)
        grid->tree().addTile(1, Coord(16, 0, -24), value(7), true);
    return grid;
}

bool close(float a, float b)
{
    return std::abs(a - b) <= 1e-5f * (1.0f + std::abs(b));
}
bool close(const openvdb::Vec3s& a, const openvdb::Vec3s& b)
{
    return (a - b).length() <= 1e-5f * (1.0f + b.length());
}

// Every output voxel's trilinear sample, walked over the whole mapped box of the input's active
// voxels two voxels wider: the reference the walk must equal (active where any of the 8 voxels
// sampled is active, as OpenVDB's BoxSampler says).
template <class GridT>
typename GridT::Ptr everyVoxelSampled(const GridT& in, const openvdb::math::Transform::Ptr& target)
{
    typename GridT::Ptr out = GridT::create(in.background());
    out->setTransform(target);
    const CoordBBox active = in.evalActiveVoxelBoundingBox();
    openvdb::Vec3d lo(1e300), hi(-1e300);
    for (int corner = 0; corner < 8; ++corner) {
        const openvdb::Vec3d c(corner & 1 ? active.max().x() + 2 : active.min().x() - 2,
                               corner & 2 ? active.max().y() + 2 : active.min().y() - 2,
                               corner & 4 ? active.max().z() + 2 : active.min().z() - 2);
        const openvdb::Vec3d q = target->worldToIndex(in.transform().indexToWorld(c));
        lo = openvdb::math::minComponent(lo, q);
        hi = openvdb::math::maxComponent(hi, q);
    }
    auto inAcc = in.getConstAccessor();
    auto outAcc = out->getAccessor();
    Coord ijk;
    for (ijk.x() = int(std::floor(lo.x())); ijk.x() <= int(std::ceil(hi.x())); ++ijk.x())
        for (ijk.y() = int(std::floor(lo.y())); ijk.y() <= int(std::ceil(hi.y())); ++ijk.y())
            for (ijk.z() = int(std::floor(lo.z())); ijk.z() <= int(std::ceil(hi.z())); ++ijk.z()) {
                typename GridT::ValueType value;
                const openvdb::Vec3d p = in.transform().worldToIndex(target->indexToWorld(ijk));
                if (openvdb::tools::BoxSampler::sample(inAcc, p, value))
                    outAcc.setValueOn(ijk, value);
            }
    return out;
}

// The active voxels of `a` that `b` lacks or holds another value at. A sample point on a face
// of the lattice, an integer coordinate in exact arithmetic, reads a voxel with weight 0 or 1
// as the rounding of the point falls: such a voxel, active in one grid and not in the other,
// holds the background in both (to rounding) and is not counted.
template <class GridT>
size_t notIn(const GridT& a, const GridT& b)
{
    size_t differ = 0;
    auto acc = b.getConstAccessor();
    for (auto v = a.cbeginValueOn(); v; ++v) {
        CoordBBox box;
        v.getBoundingBox(box);
        for (auto ijk = box.begin(); ijk; ++ijk) {
            if (acc.isValueOn(*ijk) ? close(*v, acc.getValue(*ijk)) : close(*v, a.background()))
                continue;
            ++differ;
        }
    }
    return differ;
}

// The walk against every voxel sampled (equal), and against OpenVDB's resampler on the same grid
// without its tile: each voxel OpenVDB makes active is one of ours, with our value (its walk
// starts each leaf at its first voxel, so below an active voxel on a leaf's low face it leaves out
// the ramp (v - 1, v)). Around an active tile OpenVDB's values differ from the
// trilinear ones: its TileSampler (tools/GridTransformer.h) means to take the tile's value within
// the tile shrunk by the sampler's radius, but BBox::expand(-1) grows the box, so the tile's value
// reaches a voxel past the tile, where the samples ramp down.
template <class GridT, class Value>
void expectEveryVoxelsSample(Value value, const openvdb::math::Transform::Ptr& target, const std::string& what)
{
    const typename GridT::Ptr in = sparseGrid<GridT>(0.3, value);
    typename GridT::Ptr ours = GridT::create(in->background());
    ours->setTransform(target);
    ASSERT_FALSE(downsamplesInStages(*in, *ours)) << what;
    resampleActiveRegion(*in, *ours, nullptr);
    const typename GridT::Ptr reference = everyVoxelSampled(*in, target);
    ASSERT_GT(reference->activeVoxelCount(), 0u) << what;
    EXPECT_EQ(notIn(*reference, *ours), 0u) << what << ": voxels the walk missed or got wrong";
    EXPECT_EQ(notIn(*ours, *reference), 0u) << what << ": voxels the walk made that it should not";

    const typename GridT::Ptr noTile = sparseGrid<GridT>(0.3, value, false);
    typename GridT::Ptr oursNoTile = GridT::create(in->background()), theirs = GridT::create(in->background());
    oursNoTile->setTransform(target);
    theirs->setTransform(target);
    resampleActiveRegion(*noTile, *oursNoTile, nullptr);
    openvdb::tools::resampleToMatch<openvdb::tools::BoxSampler>(*noTile, *theirs);
    EXPECT_EQ(notIn(*theirs, *oursNoTile), 0u) << what << ": OpenVDB's voxels";
    printf("%s: %zu voxels; without the tile %zu, OpenVDB's resampler %zu\n", what.c_str(),
           size_t(ours->activeVoxelCount()), size_t(oursNoTile->activeVoxelCount()),
           size_t(theirs->activeVoxelCount()));
}

float scalar(int i)
{
    return i < 0 ? 0.0f : 300.0f + float((i * 37) % 1700);
}
openvdb::Vec3s vector(int i)
{
    return i < 0 ? openvdb::Vec3s(0.0f) : openvdb::Vec3s(float(i % 13) - 6.0f, 2.5f, float((i * 7) % 11));
}

}  // namespace

TEST(ActiveResample, EqualsEveryVoxelSampledOnEveryKindOfLattice)
{
    openvdb::initialize();
    openvdb::Mat4d rotated = openvdb::Mat4d::identity();
    rotated.preScale(openvdb::Vec3d(0.13));
    rotated.preRotate(openvdb::math::Z_AXIS, 0.4);
    rotated.postRotate(openvdb::math::X_AXIS, -1.1);
    rotated.postTranslate(openvdb::Vec3d(0.05, -0.3, 0.21));
    openvdb::Mat4d sheared = openvdb::Mat4d::identity();  // skewed, one axis mirrored: no decomposition
    sheared.setRow(0, openvdb::Vec4d(0.11, 0.0, 0.03, 0.0));
    sheared.setRow(1, openvdb::Vec4d(0.02, -0.09, 0.0, 0.0));
    sheared.setRow(2, openvdb::Vec4d(0.0, 0.04, 0.12, 0.0));
    sheared.setRow(3, openvdb::Vec4d(0.017, 0.0, -0.4, 1.0));
    openvdb::Mat4d offLattice = openvdb::Mat4d::identity();
    offLattice.preScale(openvdb::Vec3d(0.29));
    offLattice.postTranslate(openvdb::Vec3d(0.1, 0.0, -0.07));
    openvdb::Mat4d thin = openvdb::Mat4d::identity();  // the fuzzed file's kind: one axis much finer
    thin.preScale(openvdb::Vec3d(0.2, 0.03, 0.1));
    struct Case {
        const char* what;
        openvdb::math::Transform::Ptr target;
    } cases[] = {
        {"3x finer", openvdb::math::Transform::createLinearTransform(0.1)},
        {"finer, rotated and moved", affine(rotated)},
        {"sheared and mirrored", affine(sheared)},
        {"one axis 10x finer", affine(thin)},
        {"slightly finer, off the lattice", affine(offLattice)},
        {"1.9x coarser", openvdb::math::Transform::createLinearTransform(0.57)},
    };
    for (const Case& c : cases) {
        expectEveryVoxelsSample<openvdb::FloatGrid>(scalar, c.target, std::string("float, ") + c.what);
        expectEveryVoxelsSample<openvdb::Vec3SGrid>(vector, c.target, std::string("vec3, ") + c.what);
    }
}

// Where the output is more than twice as coarse, OpenVDB filters in halving stages, and the
// caller keeps its resampler: downsamplesInStages must say so exactly there (not for a sheared
// map, which OpenVDB samples directly).
TEST(ActiveResample, StagedDownsamplingIsLeftToOpenVdb)
{
    openvdb::initialize();
    openvdb::FloatGrid in, out;
    in.setTransform(openvdb::math::Transform::createLinearTransform(0.1));
    for (const auto& [voxel, staged] : {std::pair{0.05, false}, std::pair{0.19, false}, std::pair{0.2, false},
                                        std::pair{0.21, true}, std::pair{1.0, true}}) {
        out.setTransform(openvdb::math::Transform::createLinearTransform(voxel));
        EXPECT_EQ(downsamplesInStages(in, out), staged) << voxel;
    }
    openvdb::Mat4d sheared = openvdb::Mat4d::identity();
    sheared.setRow(0, openvdb::Vec4d(1.0, 0.0, 0.5, 0.0));
    sheared.setRow(1, openvdb::Vec4d(0.0, 1.0, 0.0, 0.0));
    sheared.setRow(2, openvdb::Vec4d(0.0, 0.0, 1.0, 0.0));
    out.setTransform(affine(sheared));
    EXPECT_FALSE(downsamplesInStages(in, out));
}

TEST(ActiveResample, OneThreadGivesWhatManyGive)
{
    openvdb::initialize();
    const openvdb::FloatGrid::Ptr in = sparseGrid<openvdb::FloatGrid>(0.3, scalar);
    auto resample = [&] {
        openvdb::FloatGrid::Ptr out = openvdb::FloatGrid::create(0.0f);
        out->setTransform(openvdb::math::Transform::createLinearTransform(0.07));
        resampleActiveRegion(*in, *out, nullptr);
        return out;
    };
    const openvdb::FloatGrid::Ptr many = resample();
    openvdb::FloatGrid::Ptr one;
    tbb::task_arena(1).execute([&] { one = resample(); });
    ASSERT_EQ(one->activeVoxelCount(), many->activeVoxelCount());
    auto acc = many->getConstAccessor();
    size_t differ = 0;
    for (auto v = one->cbeginValueOn(); v; ++v)
        differ += !(acc.isValueOn(v.getCoord()) && acc.getValue(v.getCoord()) == *v);
    EXPECT_EQ(differ, 0u);
}
