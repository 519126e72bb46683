// MemoryEstimate.cpp: see MemoryEstimate.h. The per-item models, each a count times the bytes the
// structure stores per element (the structures' own memoryBytes() once built):
// - film: pixels x the AOVs' channels x 4 bytes (FilmLayout.h decides the AOVs);
// - deep film: per pixel a vector header and at most output.deep_samples samples (an upper bound);
// - deep shadow maps: per face, resolution^2 texels (an orthographic map's resolution capped as
//   ShadowMapProjection.cpp caps it) x kShadowMapTexelBytes (compressed vertices
//   and offsets, DeepShadowMap.h) plus the bake on the voxels, one float per density voxel
//   (LightCache.h: the density grids' brick pool again); while a map is built, its uncompressed
//   marches (DeepShadowMap::marchRay, 16 bytes a vertex, one a step of render.shadow_step voxels
//   along at most the volumes' diagonal, twice that for the vectors' spare capacity): per worker
//   one texel ray, or a whole row of them where an orthographic map over one grey volume marches
//   its rows together; the largest map's, as the maps are built one after another;
// - sky grids: per volume n^3 nodes x 4 (J+1)^2 floats ((J+1)^2 rounded up to even), n =
//   light_volume_resolution or 32 and J = wkb_sh_order_max (SkyLight.h);
// - light pyramids: the WKB plan's own estimate (WkbPlanner.cpp);
// - WKB's traced orders-3+ cache: its grid and partial grids while filled (Orders3Grid.cpp);
// - camera-ray batches: per worker at most kBatchRays rays (TileDriver.cpp) of kRayBytes plus
//   three floats per light;
// - path tracer: the kernel scene's host arrays and their device copies (on a CPU device both
//   are host memory), two per brick pool, plus the accumulation buffer (two floats per film
//   channel: mean and variance), the saved paths of one launch's range (LaunchSize.h) and the
//   kernel BVH twice, and the OpenCL runtime (a constant
//   measured with pocl, below).
#include "MemoryEstimate.h"

#include "IntegratorRegistry.h"

#include "../render/DeepFilm.h"
#include "../render/FilmLayout.h"
#include "../pathtracer/LaunchSize.h"
#include "../render/RenderContext.h"
#include "../scene/SceneValidate.h"
#include "../vrl/Orders3Grid.h"
#include "../wkb/WkbPlanner.h"

#include "../core/FormatBytes.h"
#include "../core/MemoryLimit.h"

#include <tbb/info.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <sys/resource.h>
#include <unistd.h>

namespace nimbus {

namespace {

// Measured on the default scene's two 256^2 orthographic maps (3.7 MiB each, --explain): bytes
// per texel of the compressed map. A denser medium keeps more vertices per texel; the bake on
// the voxels, usually larger, is exact.
constexpr size_t kShadowMapTexelBytes = 64;
// TileDriver.cpp: camera rays per batch per worker, and the bytes each holds (origin, direction,
// RNG state, CameraSample, sample position and time, tFar, with the vectors' slack).
constexpr size_t kBatchRays = 4096;
constexpr size_t kRayBytes = 160;
// The OpenCL runtime's own host memory once the path tracer's context and program exist, with the
// kernel binary from the kernel cache: measured with pocl's CPU device (a 16x16, spp 1 render:
// 90 MiB between the modelled items and the peak). A cold kernel cache adds the compiler's
// transient memory (about 200 MiB with pocl), not modelled (docs/robustness.md).
constexpr size_t kOpenClRuntimeBytes = size_t(90) << 20;

size_t filmChannels(const Scene& scene, const IntegratorTraits& traits)
{
    Scene one = scene;
    one.camera.width = one.camera.height = 1;
    Film film;
    setupFilm(film, one, traits, false);
    size_t channels = 0;
    for (const Aov& aov : film.aovs)
        channels += size_t(aov.channels);
    return channels;
}

}  // namespace

size_t residentBytes()
{
    std::ifstream in("/proc/self/statm");
    size_t pages = 0, resident = 0;
    if (!(in >> pages >> resident))
        return 0;
    return resident * size_t(::sysconf(_SC_PAGESIZE));
}

size_t peakResidentBytesSoFar()
{
    struct rusage usage;
    return ::getrusage(RUSAGE_SELF, &usage) == 0 ? size_t(usage.ru_maxrss) * 1024 : 0;
}

MemoryPlan estimateMemory(const Scene& scene, const RenderContext& ctx, const RenderPlan& plan)
{
    const RenderSettings& r = scene.render;
    const IntegratorEntry& entry = integratorEntry(r.method);
    MemoryPlan m;
    m.residentBytes = residentBytes();
    m.peakSoFar = peakResidentBytesSoFar();
    m.limitDefault = !(r.memoryLimit > 0);
    m.limitBytes = memoryLimitBytes(double(r.memoryLimit));

    size_t densityBytes = 0;
    for (const VolumePlan& v : plan.volumes)
        densityBytes += v.memoryBytes;
    const size_t pixels = size_t(scene.camera.width) * size_t(scene.camera.height);
    const size_t channels = filmChannels(scene, entry.traits);
    m.items.push_back({"film", pixels * channels * sizeof(float)});
    if (!scene.output.deep.empty())
        m.items.push_back({"deep film (at most)",
                           pixels * (3 * sizeof(void*) + size_t(scene.output.deepSamples) * sizeof(DeepSample))});

    if (entry.traits.shadowMaps) {
        size_t maps = 0, bakes = 0, sky = 0;
        double marches = 0.0;  // bytes, in double: a tiny shadow_step makes it astronomic
        const auto& vols = ctx.volumes.volumes();
        const float3 extent = ctx.volumes.worldBounds().hi - ctx.volumes.worldBounds().lo;
        const double voxel = double(ctx.volumes.minVoxelSize());
        const double diagonalVoxels =
            voxel > 0.0
                ? std::sqrt(double(extent.x) * extent.x + double(extent.y) * extent.y + double(extent.z) * extent.z) /
                      voxel
                : 0.0;
        const double workers = double(r.threads > 0 ? r.threads : tbb::info::default_concurrency());
        const bool rowsTogether = vols.size() == 1 && vols[0]->density.channels() == 1;
        const int n = r.lightVolumeResolution > 0 ? r.lightVolumeResolution : 32;
        const size_t shCoefficients = size_t(r.wkbShOrderMax + 1) * size_t(r.wkbShOrderMax + 1);
        for (size_t i = 0; i < plan.lights.size(); ++i) {
            const LightPlan& l = plan.lights[i];
            if (!l.used)
                continue;
            if (l.shadowMap) {
                const size_t faces = l.projection == "cube" ? 6 : 1;
                size_t res = size_t(l.resolution);
                if (l.projection == "orthographic") {
                    // ShadowMapProjection.cpp caps an orthographic map at 0.75 of the finest voxel
                    // across its footprint, at most the bounds' diagonal.
                    const Bbox& b = ctx.volumes.worldBounds();
                    const float3 e = b.hi - b.lo;
                    const double diagonal = std::sqrt(double(e.x) * e.x + double(e.y) * e.y + double(e.z) * e.z);
                    const double cap = std::ceil(diagonal / (0.75 * double(ctx.volumes.minVoxelSize())));
                    if (cap < double(res))
                        res = std::max<size_t>(8, size_t(cap));
                }
                maps += faces * res * res * kShadowMapTexelBytes;
                bakes += densityBytes;
                const double raysAtOnce = l.projection == "orthographic" && rowsTogether ? double(res) : 1.0;
                const double vertices = diagonalVoxels / double(r.shadowStep) + 2.0;
                marches = std::max(marches, workers * raysAtOnce * vertices * 2.0 * 16.0);
            }
            if (l.skyGrid)
                sky += plan.volumes.size() * size_t(n) * size_t(n) * size_t(n) * 4 * ((shCoefficients + 1) & ~size_t(1)) *
                       sizeof(float);
        }
        m.items.push_back({"deep shadow maps", maps});
        // Capped at 2^62 bytes (the size_t sum stays finite; any limit refuses it).
        m.items.push_back({"deep shadow map marches, while built",
                           marches < 4.6e18 ? size_t(marches) : (size_t(1) << 62)});
        m.items.push_back({"shadow bakes on the voxels", bakes});
        m.items.push_back({"sky grids", sky});
    }
    if (plan.wkb.enabled && plan.wkb.lightGrid)
        m.items.push_back({"light pyramids", plan.wkb.pyramidBytes});
    const auto* wkbSetup = dynamic_cast<const wkb::WkbSetup*>(plan.integrator.get());
    if (wkbSetup && wkbSetup->active && wkbSetup->tracedOrders3) {  // IntegratorRegistry.cpp builds it then
        vrl::Orders3Options o;
        o.paths = r.wkbOrders3Paths;
        o.maxPaths = vrl::orders3PathCap(*ctx.scene);
        o.maxCells = vrl::orders3GridCells(ctx);
        m.items.push_back({"orders-3+ radiance cache, while filled", vrl::orders3FillBytes(ctx, o)});
        // Its light paths walk the path tracer's flattened volumes (buildPathtraceScene): a copy of
        // the brick tables, pools and majorants while they are traced. Left out until session 30,
        // wkb's estimate was 0.74 of the measured peak at 1024 voxels across (docs/benchmarks.md).
        m.items.push_back({"orders-3+ light paths' flattened volumes, while traced", densityBytes});
    }
    if (r.method == Method::Vrl)  // the same copy, for the whole render (VrlIntegrator)
        m.items.push_back({"flattened volumes for the light paths", densityBytes});
    if (r.method != Method::Pathtrace) {  // single and wkb march camera rays in batches
        const size_t workers = size_t(r.threads > 0 ? r.threads : tbb::info::default_concurrency());
        m.items.push_back({"camera-ray batches",
                           workers * kBatchRays * (kRayBytes + 3 * plan.lights.size() * sizeof(float))});
    }
    if (r.method == Method::Pathtrace) {
        // The saved paths of one launch's range (LaunchSize.h, bounded launches).
        const size_t pathStates =
            std::min(pixels, kMaxRangeItems) * pathStateBytesBound(plan.lights.size(), ctx.volumes.volumes().size());
        m.items.push_back({"kernel buffers", 2 * densityBytes + 2 * plan.kernelBvhBytes +
                                                 pixels * channels * 2 * sizeof(float) + pathStates});
        m.items.push_back({"OpenCL runtime", kOpenClRuntimeBytes});
    }

    size_t total = m.residentBytes;
    for (const auto& item : m.items)
        total += item.bytes;
    m.estimateBytes = std::max(total, m.peakSoFar);
    return m;
}

namespace {

// The scene key that sizes an item of estimateMemory's (by the names it gives them), for the
// advice of the error; nullptr where no one key does.
const char* keySizing(const std::string& item)
{
    static const std::pair<const char*, const char*> keys[] = {
        {"film", "camera.resolution"},
        {"deep film (at most)", "output.deep_samples"},
        {"deep shadow maps", "render.shadow_map_resolution"},
        {"deep shadow map marches, while built", "render.shadow_step"},
        {"sky grids", "render.light_volume_resolution"},
        {"orders-3+ radiance cache, while filled", "render.wkb_orders3_grid"},
        {"kernel buffers", "camera.resolution"},
    };
    for (const auto& [name, key] : keys)
        if (item == name)
            return key;
    return nullptr;
}

}  // namespace

void checkMemoryLimit(const Scene& scene, const MemoryPlan& m)
{
    if (m.estimateBytes <= m.limitBytes)
        return;
    char limit[64];
    std::snprintf(limit, sizeof limit, "%.4g", double(m.limitBytes));
    // The largest part, and the key that sizes it, where one does: the setting to change first.
    std::string largest;
    if (auto it = std::max_element(m.items.begin(), m.items.end(),
                                   [](const auto& a, const auto& b) { return a.bytes < b.bytes; });
        it != m.items.end() && it->bytes > m.limitBytes / 2) {
        largest = "; its largest part, the " + it->name + ", " + formatBytes(it->bytes);
        if (const char* key = keySizing(it->name))
            largest += std::string(", follows ") + key;
    }
    throwSceneError(scene.sourcePath, "render.memory_limit",
                    "this render needs an estimated " + formatBytes(m.estimateBytes) + " (`nimbus info` lists it), over the " +
                        (m.limitDefault ? "default limit of " : "limit of ") + formatBytes(m.limitBytes) + " (" + limit +
                        " bytes)" + largest +
                        "; raise render.memory_limit (bytes) or lower the resolution, spp or volume detail");
}

}  // namespace nimbus
