// VoxelClamp.h: the bad values of a fog volume's grids (negative, NaN, infinite) set to 0 and
// counted, and reported in one warning per volume (DESIGN "Coefficients": negative density is a
// user error to warn about, not a crash; docs/volumes.md). Apart from reading the files: the
// grids from a generator, a plugin or a shader are clamped the same way.
#pragma once

#include <openvdb/openvdb.h>

#include <cstdint>
#include <string>
#include <utility>
#include <vector>

namespace nimbus {

struct ClampCount {
    uint64_t negative = 0, nan = 0, infinite = 0;
    uint64_t total() const { return negative + nan + infinite; }
    void add(const ClampCount& o)
    {
        negative += o.negative;
        nan += o.nan;
        infinite += o.infinite;
    }
};

// Clamps the active values of a fog volume to [0, inf): negative, NaN and infinite values
// become 0. Instantiated for openvdb::FloatGrid and openvdb::Vec3SGrid.
template <class GridT>
ClampCount clampGrid(GridT& grid);

// The clamps of one volume, by grid, for its one warning.
class ClampReport {
public:
    // Adds what was clamped in grid `name` (a grid clamped before and after the shader adds up).
    void add(const std::string& name, const ClampCount& c);
    // Logs the volume's one warning, if anything was clamped; returns the values clamped.
    uint64_t warn(const std::string& volumeLabel) const;

private:
    std::vector<std::pair<std::string, ClampCount>> mClamped;
};

}  // namespace nimbus
