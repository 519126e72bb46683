#include "WkbPlanner.h"

#include "LightPyramid.h"
#include "../render/SphericalHarmonics.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <tuple>

namespace nimbus::wkb {

namespace {

constexpr double kPi = 3.14159265358979323846;
// An area light subtending less than this half-angle from every volume is a direction for L2+:
// its SH expansion would need orders far beyond wkb_sh_order_max, and the blur of L2+ is wider.
constexpr double kDeltaHalfAngleDeg = 15.0;
constexpr int kShOrderLimit = 8;

std::string fmt(const char* f, double a, double b = 0, double c = 0)
{
    char buf[200];
    std::snprintf(buf, sizeof buf, f, a, b, c);
    return buf;
}

// 4 pi times the largest value of the phase function: the N-fold convolutions of a normalised
// phase function never exceed it, which bounds every angular factor of L2+.
double phasePeak4Pi(const NbPhase& p)
{
    auto peak = [](double g) {
        g = std::min(std::fabs(g), 0.999999);
        return (1.0 + g) / ((1.0 - g) * (1.0 - g));
    };
    double a = peak(p.g);
    return p.blend > 0.0f ? std::max(a, peak(p.g2)) : a;
}

float largestExtentVoxels(const BrickGrid& density)
{
    const Bbox& b = density.activeIndexBounds();
    if (b.empty())
        return 1.0f;
    float3 e = b.extent();
    return std::max(1.0f, std::max(e.x, std::max(e.y, e.z)));
}

}  // namespace

Order2Choice chooseOrder2(const RenderContext& ctx)
{
    if (ctx.shadowCasters())
        return {false, "a shadow caster's sharp shadow edges"};
    for (const LightEntry& e : ctx.lights)
        if (e.used && e.light.type == NB_LIGHT_SPOT)
            return {false, "a spot light's cone edge"};
    return {true, "no spot light and no shadow caster"};
}

std::vector<Int3> lightGridBricks(const BrickGrid& density, int factor)
{
    std::vector<Int3> out;
    const Int3 dims = density.dims();
    for (int z = 0; z < dims.z; ++z)
        for (int y = 0; y < dims.y; ++y)
            for (int x = 0; x < dims.x; ++x)
                if (density.table()[(size_t(z) * dims.y + y) * dims.x + x] >= 0)
                    out.push_back({x / factor, y / factor, z / factor});
    std::sort(out.begin(), out.end(),
              [](const Int3& a, const Int3& b) { return std::tie(a.z, a.y, a.x) < std::tie(b.z, b.y, b.x); });
    out.erase(std::unique(out.begin(), out.end(),
                          [](const Int3& a, const Int3& b) { return a.x == b.x && a.y == b.y && a.z == b.z; }),
              out.end());
    return out;
}

size_t estimatePyramidBytes(const BrickGrid& density, int factor, int channels, float maxSigma, int* levels)
{
    std::vector<Int3> bricks = lightGridBricks(density, factor);
    size_t bytes = LightPyramid::levelBytes(bricks, channels);
    int k = 1;
    for (; k < LightPyramid::kMaxLevels && LightPyramid::sigmaOfLevel(float(k - 1)) < maxSigma && !bricks.empty();
         ++k) {
        bricks = LightPyramid::coarserBricks(bricks);
        bytes += LightPyramid::levelBytes(bricks, channels);
    }
    if (levels)
        *levels = k;
    return bytes;
}

WkbSetup planWkb(const RenderContext& ctx, RenderPlan& plan)
{
    const RenderSettings& rs = ctx.scene->render;
    WkbSetup setup;
    setup.kernel = rs.wkbKernel == WkbKernel::Exact ? KernelType::Exact : KernelType::Gaussian;
    setup.randomWalk = rs.wkbSource == WkbSource::RandomWalk;
    setup.tracedOrder2 = rs.wkbOrder2 == WkbOrder2::Traced || rs.wkbOrder2 == WkbOrder2::Auto;
    setup.blurK = std::max(0.0f, rs.wkbBlurK);
    setup.lStep = std::max(1e-3f, rs.wkbLStep);
    setup.tolerance = std::max(1e-7f, rs.tolerance);
    setup.orderCap = std::max(0, rs.wkbOrderMax);

    WkbPlan& wp = plan.wkb;
    wp.enabled = true;
    wp.kernel = setup.kernel == KernelType::Gaussian ? "gaussian phase (e^l - 1) A_j(l)"
                                                     : "exact infinite medium e^{l p_j} - 1";
    wp.source = setup.randomWalk ? "random walk (mean displacement, walk variance)" : "straight line (sec. 6.3.6)";
    // The traced cache's reach: the optical depth of the densest voxel (VolumeData::voxelSize, the
    // smallest edge) at the largest extinction of any channel.
    double depthPerVoxel = 0.0;
    for (const auto& v : ctx.volumes.volumes())
        depthPerVoxel = std::max(depthPerVoxel, double(nbMaxComponent(v->sigmaT())) * double(v->density.maxValue()) *
                                                    double(v->voxelSize));
    // Nor where a volume moves by its transform within the shutter: there the cache and its read
    // disagree (cli_transform_blur's transform = velocity blur check failed with it, strip z up to
    // 7.8; velocity blur, a moving camera and moving lights pass with it).
    bool transformMoves = false;
    for (const Volume& v : ctx.scene->volumes)
        transformMoves = transformMoves || v.shutterMotion.animated();
    setup.tracedOrders3 =
        rs.wkbOrders3 == WkbOrders3::Traced && !(depthPerVoxel > kTracedOrders3MaxDepth) && !transformMoves;
    if (rs.wkbOrders3 == WkbOrders3::Traced && transformMoves)
        plan.notes.push_back("wkb: orders 3+ by the kernel, not traced: a volume moves by its transform within the "
                             "shutter, which the traced cache does not follow");
    else if (rs.wkbOrders3 == WkbOrders3::Traced && !setup.tracedOrders3)
        plan.notes.push_back(fmt("wkb: orders 3+ by the kernel, not traced: optical depth %.3g per voxel, over the "
                                 "traced cache's %.0f",
                                 depthPerVoxel, kTracedOrders3MaxDepth));
    const bool tracedOrders3 = setup.tracedOrders3;
    if (rs.wkbOrder2 == WkbOrder2::Auto && tracedOrders3) {
        const Order2Choice choice = chooseOrder2(ctx);
        setup.cachedOrder2 = choice.cache;
        setup.tracedOrder2 = !choice.cache;
        plan.notes.push_back(std::string("wkb: order 2 ") +
                             (choice.cache ? "from the radiance cache" : "traced per camera ray") +
                             " (render.wkb_order2 auto: " + choice.reason + ")");
    } else if (rs.wkbOrder2 == WkbOrder2::Cache) {
        // In the cache where there is one; else traced per camera ray.
        setup.cachedOrder2 = tracedOrders3;
        setup.tracedOrder2 = !tracedOrders3;
        if (!tracedOrders3)
            plan.notes.push_back("wkb: order 2 traced per camera ray, not from the cache: no traced radiance cache "
                                 "in this scene (render.wkb_orders3)");
    }
    if (setup.cachedOrder2)
        wp.kernel += "; orders 2+ from the traced radiance cache, the kernel for emission";
    else if (setup.tracedOrder2 && tracedOrders3)
        wp.kernel += "; order 2 traced, orders 3+ from the traced radiance cache, the kernel for emission";
    else if (setup.tracedOrder2)
        wp.kernel += "; order 2 traced, the kernel from order 3";
    else if (tracedOrders3)
        wp.kernel += "; the kernel for order 2, orders 3+ from the traced radiance cache";
    wp.blurK = setup.blurK;
    wp.lStep = setup.lStep;
    wp.orderCap = setup.orderCap;
    wp.memoryBudget = rs.wkbMemoryBudget;

    const auto& vols = ctx.volumes.volumes();
    setup.volumes.resize(vols.size());
    for (size_t i = 0; i < ctx.lights.size() && i < plan.lights.size(); ++i)
        plan.lights[i].l2plus = "skipped: no L2+ in this scene";
    if (vols.empty()) {
        plan.notes.push_back("wkb: no volume, L2+ is zero");
        return setup;
    }

    // Optical size: the largest scattering depth across each volume bounds the scattering
    // length l of any camera ray there. L2+ needs at least two scatterings:
    // sum_{N>=2} e^{-l} l^N / N! <= l^2 / 2, and every angular factor is at most the phase peak.
    double lTotal = 0.0, peak = 1.0, gmax = 0.0, p1max = -1.0;
    std::vector<double> lv(vols.size());
    for (size_t v = 0; v < vols.size(); ++v) {
        const VolumeData& d = *vols[v];
        Rgb s = d.sigmaS(), t = d.sigmaT();
        lv[v] = double(nbMaxComponent(s)) * d.density.maxValue() * length(d.worldBounds.extent());
        lTotal += lv[v];
        for (float a : {s.x / std::max(t.x, 1e-30f), s.y / std::max(t.y, 1e-30f), s.z / std::max(t.z, 1e-30f)})
            setup.omegaMax = std::max(setup.omegaMax, double(std::min(a, 1.0f)));
        peak = std::max(peak, phasePeak4Pi(d.medium.phase));
        gmax = std::max(gmax, nbPhaseMomentBound(d.medium.phase));
        p1max = std::max(p1max, nbPhaseMeanCos(d.medium.phase));
    }
    const double bound = 0.5 * lTotal * lTotal * peak;
    wp.l2plusBound = bound;
    for (size_t v = 0; v < vols.size(); ++v) {
        // Paths with at least two scatterings, the last in volume v: <= l_v l_total peak.
        setup.volumes[v].bound = lv[v] * lTotal * peak;
        setup.volumes[v].l2plus = setup.volumes[v].bound >= setup.tolerance;
    }
    if (bound < setup.tolerance) {
        plan.notes.push_back(
            fmt("wkb: L2+ skipped: optically thin (scattering depth <= %.3g, bound %.2g E/4pi < tolerance %.2g)",
                lTotal, bound, setup.tolerance));
        for (size_t v = 0; v < vols.size() && v < plan.volumes.size(); ++v) {
            plan.volumes[v].l2plus = false;
            plan.volumes[v].l2plusBound = setup.volumes[v].bound;
        }
        return setup;
    }

    // Sources. The SH order is the fewest orders whose neglected terms at the first march step
    // (l = l_step / 2, where the angular factors are largest) stay under the tolerance, capped.
    const int shCap = std::min(std::max(rs.wkbShOrderMax, 0), kShOrderLimit);
    const int shOrder =
        truncateOrders(setup.kernel, 0.5 * setup.lStep, gaussianMu(p1max), gmax, setup.tolerance, shCap).order;
    {
        // The order sum is longest at the first step; say so where the cap cuts it there.
        Truncation first =
            truncateOrders(setup.kernel, 0.5 * setup.lStep, gaussianMu(p1max), gmax, setup.tolerance, setup.orderCap);
        if (first.capped)
            plan.notes.push_back(
                fmt("wkb: the order sum is capped at j = %.0f at the first step (l = %.3g); the neglected "
                    "terms are bounded by %.2g E/4pi there",
                    first.order, 0.5 * setup.lStep, first.tailBound * 4.0 * kPi) +
                fmt(" (max |g| %.3g)", gmax));
    }
    // Both of the lights' parts the kernel would give are traced (WkbIntegrator: the kernel is then
    // left with emission).
    const bool lightsTraced = tracedOrders3 && (setup.tracedOrder2 || setup.cachedOrder2);
    const Bbox& vb = ctx.volumes.worldBounds();
    const float3 vc = vb.center();
    const float vr = 0.5f * length(vb.extent());
    int offset = 1;
    for (size_t i = 0; i < ctx.lights.size(); ++i) {
        const LightEntry& e = ctx.lights[i];
        const Light& l = ctx.scene->lights[i];
        SourcePlan sp;
        sp.lightIndex = int(i);
        sp.light = e.light;
        if (!e.used) {
            sp.description = "skipped: the light reaches no volume";
        } else if (e.delta || l.type == LightType::Point || l.type == LightType::Spot) {
            sp.mode = SourceMode::Delta;
            sp.directional = l.type == LightType::Distant;
            sp.needsOwnShadowMap = !e.delta;  // the context shadow-maps exactly its delta lights
            sp.description = "delta source: E = weight * T from the deep shadow map";
        } else if (l.type == LightType::Distant) {
            sp.mode = SourceMode::Delta;
            sp.directional = true;
            sp.needsOwnShadowMap = true;
            sp.description =
                fmt("delta source: a %.3g deg sun as its centre (L2+ blurs wider than its penumbra), own shadow map",
                    l.angle);
        } else if (l.type == LightType::Rect || l.type == LightType::Sphere) {
            float3 c = l.type == LightType::Rect ? l.center : l.position;
            double rl = l.type == LightType::Rect ? 0.5 * std::hypot(l.size[0], l.size[1]) : l.radius;
            double gap = length(c - vc) - vr;
            double half = gap > rl ? std::asin(std::min(1.0, rl / gap)) * 180.0 / kPi : 90.0;
            if (half < kDeltaHalfAngleDeg) {
                sp.mode = SourceMode::Delta;
                sp.needsOwnShadowMap = true;
                sp.description = fmt("delta source: subtends <= %.3g deg, a point at its centre, own shadow map", half);
            } else {
                sp.mode = SourceMode::Sh;
                sp.order = shOrder;
                sp.description = fmt("SH order %.0f (%.0f channels): subtends up to %.3g deg", shOrder,
                                     3.0 * shCount(shOrder), half);
            }
        } else {
            sp.mode = SourceMode::Sh;
            sp.order = shOrder;
            sp.description = fmt("SH order %.0f (%.0f channels)", shOrder, 3.0 * shCount(shOrder));
        }
        if (sp.mode != SourceMode::Skip && lightsTraced) {
            // Neither of the kernel's parts reads this light: no channels, no shadow map built
            // for it (at 1024 voxels across, a sky's 32 shadow rays per light voxel were 95%
            // of a 27-minute render: docs/benchmarks.md "Scale").
            sp.kernel = false;
            sp.needsOwnShadowMap = false;
            sp.description = setup.cachedOrder2 ? "traced: orders 2+ from the radiance cache (no light volume)"
                                                : "traced: order 2 per camera ray, orders 3+ from the radiance cache "
                                                  "(no light volume)";
        } else if (sp.mode != SourceMode::Skip) {
            sp.offset = offset;
            sp.channelCount = sp.mode == SourceMode::Delta ? 3 : 3 * shCount(sp.order);
            offset += sp.channelCount;
        }
        if (i < plan.lights.size())
            plan.lights[i].l2plus = sp.description;
        setup.sources.push_back(sp);
    }
    if (ctx.volumes.hasEmission()) {
        SourcePlan sp;
        sp.mode = SourceMode::Sh;
        sp.emission = true;
        sp.order = std::min(1, shCap);
        sp.offset = offset;
        sp.channelCount = 3 * shCount(sp.order);
        offset += sp.channelCount;
        sp.description = fmt("emission as a light source (Tessendorf sec. 3.4.4): SH order %.0f", sp.order);
        plan.notes.push_back("wkb: " + sp.description);
        setup.sources.push_back(sp);
    }
    setup.channels = offset;
    wp.channels = offset;
    bool anySource = false;
    setup.kernelSources = false;
    for (const SourcePlan& sp : setup.sources) {
        anySource |= sp.mode != SourceMode::Skip;
        setup.kernelSources |= sp.mode != SourceMode::Skip && sp.kernel;
    }
    wp.lightGrid = setup.kernelSources;
    if (!anySource) {
        plan.notes.push_back("wkb: no light reaches a volume, L2+ is zero");
        return setup;
    }

    // Light-grid resolution: the finest power-of-two multiple of the density voxel (at least 2)
    // whose pyramids all fit in wkb_memory_budget times the density grids' memory, unless
    // light_volume_resolution asks for a size.
    size_t densityBytes = 0;
    float largest = 1.0f;
    for (auto& v : vols) {
        densityBytes += v->density.memoryBytes();
        largest = std::max(largest, largestExtentVoxels(v->density));
    }
    wp.densityBytes = densityBytes;
    auto estimate = [&](int factorAuto, bool commit) {
        size_t total = 0;
        for (size_t v = 0; v < vols.size(); ++v) {
            VolumeSetup& vs = setup.volumes[v];
            int f = factorAuto;
            if (rs.lightVolumeResolution > 0) {
                double want = largestExtentVoxels(vols[v]->density) / double(rs.lightVolumeResolution);
                f = 1;
                while (f < 1 << 14 && 2.0 * f <= want * 1.4142)
                    f *= 2;
            }
            const int channels = vs.l2plus ? setup.channels : 1;
            const float maxSigma = largestExtentVoxels(vols[v]->density) / float(f);
            int levels = 0;
            const size_t bytes =
                setup.kernelSources ? estimatePyramidBytes(vols[v]->density, f, channels, maxSigma, &levels) : 0;
            total += bytes;
            if (commit) {
                vs.factor = f;
                vs.origin = lightGridOrigin(vols[v]->density);
                vs.channels = channels;
                vs.maxSigma = maxSigma;
                vs.levels = levels;
                vs.bytes = bytes;
                vs.lightVoxel = vols[v]->voxelSize * float(f);
            }
        }
        return total;
    };
    int factor = 2;
    const double budget = double(std::max(rs.wkbMemoryBudget, 0.0f)) * double(densityBytes);
    if (rs.lightVolumeResolution <= 0)
        while (double(estimate(factor, false)) > budget && float(factor) * BrickGrid::kBrick < largest)
            factor *= 2;
    wp.pyramidBytes = estimate(factor, true);
    if (double(wp.pyramidBytes) > budget)
        plan.notes.push_back(fmt("wkb: light pyramids %.3g x the density memory, over the budget of %.3g: the coarsest "
                                 "useful light grid is still larger",
                                 double(wp.pyramidBytes) / std::max<double>(1.0, double(densityBytes)),
                                 rs.wkbMemoryBudget));

    for (size_t v = 0; v < vols.size() && v < plan.volumes.size(); ++v) {
        const VolumeSetup& vs = setup.volumes[v];
        VolumePlan& vp = plan.volumes[v];
        vp.l2plus = vs.l2plus;
        vp.l2plusBound = vs.bound;
        vp.lightVoxelFactor = vs.factor;
        vp.mipLevels = vs.levels;
        vp.pyramidBytes = vs.bytes;
        float3 e = vols[v]->density.activeIndexBounds().extent();
        vp.lightGrid = fmt("%.0f x %.0f x ", std::ceil(e.x / vs.factor) + 1, std::ceil(e.y / vs.factor) + 1) +
                       fmt("%.0f light voxels of %.3g m", std::ceil(e.z / vs.factor) + 1, vs.lightVoxel);
    }
    setup.active = true;
    wp.l2plus = true;
    return setup;
}

}  // namespace nimbus::wkb
