// PluginSource.cpp: loading a volume procedural plugin and sampling it into a FloatGrid.
//
// The plugin is called through plain C function pointers; nimbus owns the library handle and
// the plugin's state in RAII guards so that an error at any step still runs cleanup and
// dlclose. A C++ plugin that throws through the C interface is caught too (undefined by the
// letter of the ABI, but better a message than std::terminate in a DCC session).
#include "PluginSource.h"
#include "InputFiles.h"

#include "../abi/nimbus_volume_plugin.h"
#include "../core/Error.h"
#include "../core/StopFlag.h"

#include <openvdb/openvdb.h>

#include <tbb/blocked_range.h>
#include <tbb/enumerable_thread_specific.h>
#include <tbb/parallel_for.h>

#include <dlfcn.h>

#include <array>
#include <atomic>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <mutex>
#include <sstream>

namespace nimbus {

namespace fs = std::filesystem;

namespace {

using openvdb::Coord;
using openvdb::FloatGrid;
using LeafT = FloatGrid::TreeType::LeafNodeType;

// The same voxel budget as the built-in generators (Procedural.cpp): beyond it the lattice pass
// alone would take minutes and the grid gigabytes.
constexpr double kMaxVoxels = 2e8;
constexpr size_t kErrorSize = 1024;
constexpr int kBlock = 8;  // one OpenVDB leaf

std::string fileName(const std::string& path)
{
    return fs::path(path).filename().string();
}

class Library {
public:
    Library(const std::string& path, const std::string& sceneDir, const std::string& key)
    {
        std::string firstError;
        for (const std::string& candidate : pluginCandidates(path, sceneDir)) {
            // A path that names an existing file is the one meant: report its own error rather
            // than "not found" from a later candidate.
            std::error_code ec;
            bool exists = candidate.find('/') != std::string::npos && fs::exists(candidate, ec);
            dlerror();
            mHandle = dlopen(candidate.c_str(), RTLD_NOW | RTLD_LOCAL);
            if (mHandle) {
                mPath = candidate;
                return;
            }
            const char* e = dlerror();
            if (exists || firstError.empty())
                firstError = e ? e : "unknown dlopen error";
            if (exists)
                break;
        }
        throw InputError(key + ": cannot load volume plugin '" + path + "': " + firstError +
                         " (searched $NIMBUS_PLUGIN_PATH, the scene's directory and the linker's path)");
    }
    ~Library()
    {
        if (mHandle)
            dlclose(mHandle);
    }
    Library(const Library&) = delete;
    Library& operator=(const Library&) = delete;

    void* symbol(const char* name) const
    {
        dlerror();
        return dlsym(mHandle, name);
    }
    const std::string& path() const { return mPath; }

private:
    void* mHandle = nullptr;
    std::string mPath;
};

struct Entry {
    NimbusVolumePluginVersionFn version = nullptr;
    NimbusVolumeInitFn init = nullptr;
    NimbusVolumeBoundsFn bounds = nullptr;
    NimbusVolumeSampleFn sample = nullptr;
    NimbusVolumeCleanupFn cleanup = nullptr;
    NimbusVolumeBlockEmptyFn blockEmpty = nullptr;  // optional
};

template <class Fn>
Fn lookup(const Library& lib, const char* name, bool required, const std::string& key, const std::string& label)
{
    void* p = lib.symbol(name);
    if (!p && required)
        throw InputError(key + ": '" + label + "' is not a nimbus volume plugin: missing symbol " + name +
                         " (src/abi/nimbus_volume_plugin.h)");
    return reinterpret_cast<Fn>(p);
}

// init's state, cleaned up however we leave.
class State {
public:
    State(const Entry& e, void* state) : mEntry(e), mState(state) {}
    ~State()
    {
        try {
            mEntry.cleanup(mState);
        } catch (...) {
        }
    }
    State(const State&) = delete;
    State& operator=(const State&) = delete;
    void* get() const { return mState; }

private:
    const Entry& mEntry;
    void* mState;
};

std::string message(const char* buffer, const char* fallback)
{
    std::string s(buffer, strnlen(buffer, kErrorSize));
    return s.empty() ? std::string(fallback) : s;
}

bool finite3(const double* v)
{
    return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

}  // namespace

// The candidates for a library path, in search order (PluginSource.h).
std::vector<std::string> pluginCandidates(const std::string& path, const std::string& sceneDir)
{
    std::vector<std::string> out;
    fs::path p(path);
    if (p.is_absolute())
        return {path};
    if (path.find('/') != std::string::npos) {
        if (!sceneDir.empty())
            out.push_back((fs::path(sceneDir) / p).lexically_normal().string());
        out.push_back(fs::absolute(p).lexically_normal().string());
        return out;
    }
    std::vector<std::string> names = {path};
    if (path.find(".so") == std::string::npos)
        names.push_back("lib" + path + ".so");
    std::vector<std::string> dirs = searchPathDirs("NIMBUS_PLUGIN_PATH");
    if (!sceneDir.empty())
        dirs.push_back(sceneDir);
    for (const auto& dir : dirs)
        for (const auto& name : names)
            out.push_back((fs::path(dir) / name).string());
    for (const auto& name : names)
        out.push_back(name);  // bare: the dynamic linker searches
    return out;
}

std::shared_ptr<VdbFloatGrid> makePluginGrid(const VolumeSource& source, const std::string& sceneDir,
                                             const std::string& keyPath, std::vector<std::string>& gridsRead,
                                             const StopFlag* stop)
{
    const std::string key = keyPath + ".path";
    if (source.pluginPath.empty())
        throw InputError(key + ": a plugin source needs the path of a shared library");
    Library lib(source.pluginPath, sceneDir, key);
    const std::string label = fileName(lib.path());

    Entry e;
    e.version = lookup<NimbusVolumePluginVersionFn>(lib, "nimbus_volume_plugin_version", true, key, label);
    e.init = lookup<NimbusVolumeInitFn>(lib, "nimbus_volume_init", true, key, label);
    e.bounds = lookup<NimbusVolumeBoundsFn>(lib, "nimbus_volume_bounds", true, key, label);
    e.sample = lookup<NimbusVolumeSampleFn>(lib, "nimbus_volume_sample", true, key, label);
    e.cleanup = lookup<NimbusVolumeCleanupFn>(lib, "nimbus_volume_cleanup", true, key, label);
    e.blockEmpty = lookup<NimbusVolumeBlockEmptyFn>(lib, "nimbus_volume_block_empty", false, key, label);

    auto fail = [&](const std::string& what) -> InputError { return InputError(key + ": " + label + ": " + what); };
    int version = 0;
    try {
        version = e.version();
    } catch (...) {
        throw fail("nimbus_volume_plugin_version threw an exception");
    }
    if (version != NIMBUS_VOLUME_PLUGIN_VERSION)
        throw fail("built for plugin interface version " + std::to_string(version) + ", this nimbus loads version " +
                   std::to_string(NIMBUS_VOLUME_PLUGIN_VERSION));

    // init: the parameters as name/value text pairs, in key order.
    std::vector<NimbusVolumeParam> params;
    for (const auto& [name, value] : source.pluginParams)
        params.push_back({name.c_str(), value.c_str()});
    char error[kErrorSize] = {0};
    void* raw = nullptr;
    try {
        raw = e.init(params.data(), params.size(), error, kErrorSize);
    } catch (...) {
        throw fail("init threw an exception");
    }
    if (!raw)
        throw fail("init failed: " + message(error, "(no message)"));
    State state(e, raw);

    NimbusVolumeBounds b = {};
    int rc = 0;
    try {
        rc = e.bounds(state.get(), &b, error, kErrorSize);
    } catch (...) {
        throw fail("bounds threw an exception");
    }
    if (rc != 0)
        throw fail("bounds failed: " + message(error, "(no message)"));
    if (!finite3(b.min) || !finite3(b.max) || !std::isfinite(b.voxel_size) || !(b.voxel_size > 0.0))
        throw fail("bounds returned a non-finite box or a voxel size that is not > 0");
    if (b.min[0] > b.max[0] || b.min[1] > b.max[1] || b.min[2] > b.max[2])
        throw fail("bounds returned min > max");

    // The lattice x = i h over [min, max]: index range [lo, hi] per axis.
    const double h = b.voxel_size;
    Coord lo, hi;
    double voxels = 1.0;
    for (int a = 0; a < 3; ++a) {
        const double l = std::floor(b.min[a] / h), u = std::ceil(b.max[a] / h);
        if (std::fabs(l) > 1e9 || std::fabs(u) > 1e9)
            throw fail("bounds are more than 1e9 voxels from the origin; use a larger voxel size");
        lo[a] = int(l), hi[a] = int(u);
        voxels *= u - l + 1.0;
    }
    if (voxels > kMaxVoxels) {
        std::ostringstream o;
        o << "the lattice over the plugin's bounds would have " << voxels << " voxels, more than the limit of "
          << kMaxVoxels << "; return a larger voxel size";
        throw fail(o.str());
    }

    // Leaf-aligned 8^3 blocks covering [lo, hi].
    auto floor8 = [](int v) { return v >= 0 ? (v / kBlock) * kBlock : -(((-v) + kBlock - 1) / kBlock) * kBlock; };
    const Coord b0(floor8(lo.x()), floor8(lo.y()), floor8(lo.z()));
    const Coord nb((hi.x() - b0.x()) / kBlock + 1, (hi.y() - b0.y()) / kBlock + 1, (hi.z() - b0.z()) / kBlock + 1);
    const size_t blocks = size_t(nb.x()) * nb.y() * nb.z();

    std::atomic<bool> failed{false};
    std::mutex errorMutex;
    std::string sampleError;
    tbb::enumerable_thread_specific<std::vector<LeafT*>> made;
    tbb::parallel_for(tbb::blocked_range<size_t>(0, blocks, 4), [&](const tbb::blocked_range<size_t>& r) {
        std::vector<double> positions;
        std::vector<float> densities;
        std::vector<Coord> coords;
        char err[kErrorSize];
        auto& mine = made.local();
        for (size_t i = r.begin(); i != r.end() && !failed.load(std::memory_order_relaxed) && !stopRaised(stop); ++i) {
            const Coord origin(b0.x() + kBlock * int(i % nb.x()), b0.y() + kBlock * int((i / nb.x()) % nb.y()),
                               b0.z() + kBlock * int(i / (size_t(nb.x()) * nb.y())));
            Coord c0 = origin, c1 = origin + Coord(kBlock - 1);
            for (int a = 0; a < 3; ++a)
                c0[a] = std::max(c0[a], lo[a]), c1[a] = std::min(c1[a], hi[a]);
            try {
                if (e.blockEmpty) {
                    const double bmin[3] = {c0.x() * h, c0.y() * h, c0.z() * h};
                    const double bmax[3] = {c1.x() * h, c1.y() * h, c1.z() * h};
                    if (e.blockEmpty(state.get(), bmin, bmax) == 1)
                        continue;
                }
                positions.clear();
                coords.clear();
                for (int z = c0.z(); z <= c1.z(); ++z)
                    for (int y = c0.y(); y <= c1.y(); ++y)
                        for (int x = c0.x(); x <= c1.x(); ++x) {
                            coords.push_back(Coord(x, y, z));
                            positions.insert(positions.end(), {x * h, y * h, z * h});
                        }
                densities.assign(coords.size(), 0.0f);
                err[0] = 0;
                if (e.sample(state.get(), positions.data(), coords.size(), densities.data(), err, kErrorSize) != 0) {
                    std::lock_guard<std::mutex> lock(errorMutex);
                    if (!failed.exchange(true))
                        sampleError = "sample failed: " + message(err, "(no message)");
                    return;
                }
            } catch (...) {
                std::lock_guard<std::mutex> lock(errorMutex);
                if (!failed.exchange(true))
                    sampleError = "sample threw an exception";
                return;
            }
            // Zero is empty space (inactive); anything else, NaN and negatives included, is
            // stored and clamped with the counts buildVolumes reports for any grid.
            LeafT* leaf = nullptr;
            for (size_t k = 0; k < coords.size(); ++k) {
                if (densities[k] == 0.0f)
                    continue;
                if (!leaf)
                    leaf = new LeafT(origin, 0.0f, false);
                leaf->setValueOn(coords[k], densities[k]);
            }
            if (leaf)
                mine.push_back(leaf);
        }
    });

    const bool stopped = stopRaised(stop);  // blocks were skipped: the grid is not whole
    FloatGrid::Ptr grid = FloatGrid::create(0.0f);
    for (auto& list : made)
        for (LeafT* leaf : list) {
            if (failed || stopped)
                delete leaf;
            else
                grid->tree().addLeaf(leaf);  // the tree takes ownership
        }
    if (failed)
        throw fail(sampleError);
    if (stopped)
        throw Cancelled();  // the state's cleanup runs as it unwinds
    grid->setTransform(openvdb::math::Transform::createLinearTransform(h));
    grid->setName("density");
    grid->setGridClass(openvdb::GRID_FOG_VOLUME);
    gridsRead.push_back("density (plugin " + label + ")");
    return grid;
}

}  // namespace nimbus
