// bench_resample: a role grid's resample onto the density grid's lattice (src/volume/
// ActiveResample.h) against OpenVDB's resampleToMatch<BoxSampler>, which nimbus used before,
// side by side in one process, rounds alternating: a dense temperature block on a coarser
// lattice (the common case), the same under a rotation, and scattered voxels over a lattice
// 1000x finer along one axis (the fuzz_vdb slow class). Writes the table into
// docs/benchmarks.md (section "resample").
//
//     bench_resample [docs/benchmarks.md] [--rounds N]
#include "../../src/volume/ActiveResample.h"
#include "BenchReport.h"

#include <openvdb/openvdb.h>
#include <openvdb/tools/GridTransformer.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

using openvdb::Coord;
using openvdb::CoordBBox;
using openvdb::FloatGrid;

namespace {

struct Case {
    std::string what;
    FloatGrid::Ptr in;
    openvdb::math::Transform::Ptr target;
};

FloatGrid::Ptr denseBlock(int n, double voxel)
{
    FloatGrid::Ptr g = FloatGrid::create(0.0f);
    g->setTransform(openvdb::math::Transform::createLinearTransform(voxel));
    auto acc = g->getAccessor();
    for (int i = 0; i < n; ++i)
        for (int j = 0; j < n; ++j)
            for (int k = 0; k < n; ++k)
                acc.setValueOn(Coord(i, j, k), 300.0f + float((i * 7 + j * 3 + k) % 1700));  // leaves, not tiles
    return g;
}

double seconds(const std::function<void()>& f)
{
    const auto start = std::chrono::steady_clock::now();
    f();
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

}  // namespace

int main(int argc, char** argv)
{
    std::string doc;
    int rounds = 3;
    for (int i = 1; i < argc; ++i) {
        const std::string a = argv[i];
        if (a == "--rounds" && i + 1 < argc)
            rounds = std::max(1, std::atoi(argv[++i]));
        else
            doc = a;
    }
    openvdb::initialize();

    std::vector<Case> cases;
    cases.push_back({"dense 96^3 temperature of 0.2 m onto 0.1 m voxels (2x finer)", denseBlock(96, 0.2),
                     openvdb::math::Transform::createLinearTransform(0.1)});
    cases.push_back({"dense 64^3 of 0.125 m onto 0.1 m voxels (1.25x finer)", denseBlock(64, 0.125),
                     openvdb::math::Transform::createLinearTransform(0.1)});
    {
        openvdb::Mat4d m = openvdb::Mat4d::identity();
        m.preScale(openvdb::Vec3d(0.1));
        m.preRotate(openvdb::math::Y_AXIS, 0.5);
        cases.push_back({"dense 64^3 of 0.2 m onto 0.1 m voxels turned 0.5 rad", denseBlock(64, 0.2),
                         openvdb::math::Transform::createLinearTransform(m)});
    }
    {
        FloatGrid::Ptr g = FloatGrid::create(0.0f);
        g->setTransform(openvdb::math::Transform::createLinearTransform(0.1));
        std::mt19937 rng(3);
        std::uniform_int_distribution<int> at(0, 63);
        for (int i = 0; i < 40; ++i)
            g->tree().setValueOn(Coord(at(rng), at(rng) / 8, at(rng)), 1500.0f);
        openvdb::Mat4d m = openvdb::Mat4d::identity();
        m.preScale(openvdb::Vec3d(0.1, 1e-4, 0.05));
        cases.push_back({"40 scattered voxels of 0.1 m onto 0.1 x 1e-4 x 0.05 m voxels", g,
                         openvdb::math::Transform::createLinearTransform(m)});
    }

    std::ostringstream table;
    table << "Side by side in one process, " << rounds << " rounds each (the order alternating), best time of each; "
          << std::thread::hardware_concurrency()
          << " hardware threads. `voxels`: the output's active voxels, nimbus's / OpenVDB's (OpenVDB's walk leaves out "
             "the ramp below a leaf's low face, and each makes active some voxels on a lattice face that read an "
             "active voxel with weight 0).\n\n"
          << "| case | voxels (nimbus / OpenVDB) | OpenVDB s | nimbus s | OpenVDB / nimbus |\n|---|---|---|---|---|\n";
    for (const Case& c : cases) {
        double ours = 1e300, theirs = 1e300;
        size_t oursVoxels = 0, theirVoxels = 0;
        for (int r = 0; r < 2 * rounds; ++r) {
            FloatGrid::Ptr out = FloatGrid::create(0.0f);
            out->setTransform(c.target);
            if ((r % 2 == 0) == (r / 2 % 2 == 0)) {
                ours = std::min(ours, seconds([&] { nimbus::resampleActiveRegion(*c.in, *out, nullptr); }));
                oursVoxels = out->activeVoxelCount();
            } else {
                theirs = std::min(
                    theirs, seconds([&] { openvdb::tools::resampleToMatch<openvdb::tools::BoxSampler>(*c.in, *out); }));
                theirVoxels = out->activeVoxelCount();
            }
        }
        char row[512];
        std::snprintf(row, sizeof row, "| %s | %zu / %zu | %.3f | %.3f | %.2f |\n", c.what.c_str(), oursVoxels,
                      theirVoxels, theirs, ours, theirs / ours);
        table << row;
        std::fputs(row, stdout);
        std::fflush(stdout);
    }
    if (!doc.empty())
        nimbus::bench::replaceSection(doc, "resample", table.str());
    return 0;
}
