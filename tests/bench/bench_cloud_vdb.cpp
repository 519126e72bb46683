// bench_cloud_vdb: writes the default scene's procedural cloud at a given voxel size to a .vdb
// file, so that tests/bench/bench_scale.py builds each scale's volume once and its renders read
// it as a production scene would (issue 18, item 7).
//
//     bench_cloud_vdb VOXEL_SIZE OUT.vdb
#include "../../src/core/Error.h"
#include "../../src/volume/Procedural.h"

#include <cstdio>
#include <cstdlib>
#include <exception>
#include <string>

int main(int argc, char** argv)
{
    if (argc != 3) {
        std::fprintf(stderr, "usage: bench_cloud_vdb VOXEL_SIZE OUT.vdb\n");
        return 2;
    }
    try {
        nimbus::VolumeSource source;
        source.type = nimbus::SourceType::Procedural;
        source.generator = "cloud";
        source.params = {{"voxel_size", std::stod(argv[1])}};
        nimbus::writeProceduralVdb(source, argv[2]);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "bench_cloud_vdb: %s\n", e.what());
        return 1;
    }
    return 0;
}
