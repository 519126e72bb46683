#include "IntegratorRegistry.h"

#include "Renderer.h"

#include "../pathtracer/Pathtracer.h"
#include "../vrl/Orders3Grid.h"
#include "../vrl/VrlIntegrator.h"
#include "../single/SingleIntegrator.h"
#include "../wkb/WkbIntegrator.h"

#include <algorithm>
#include <chrono>
#include <stdexcept>

namespace nimbus {

namespace {

IntegratorEntry singleEntry()
{
    IntegratorEntry e;
    e.traits = singleTraits();
    e.create = [](const RenderContext& ctx, const RenderPlan&, const RenderOptions&,
                  RenderStats&) -> std::unique_ptr<Integrator> { return std::make_unique<SingleIntegrator>(ctx); };
    return e;
}

IntegratorEntry wkbEntry()
{
    IntegratorEntry e;
    e.traits = wkb::wkbTraits();
    e.plan = [](const RenderContext& ctx, RenderPlan& plan) {
        plan.integrator = std::make_shared<const wkb::WkbSetup>(wkb::planWkb(ctx, plan));
    };
    e.create = [](const RenderContext& ctx, const RenderPlan& plan, const RenderOptions& options,
                  RenderStats& stats) -> std::unique_ptr<Integrator> {
        std::shared_ptr<const wkb::RadianceGrid> orders3;
        const RenderSettings& rs = ctx.scene->render;
        // As planned (WkbSetup::tracedOrders3: not too thick per voxel), and not where the plan has
        // no L2+ (an optically thin scene, no volume): nothing would read it.
        const auto* setup = dynamic_cast<const wkb::WkbSetup*>(plan.integrator.get());
        if (setup && setup->tracedOrders3 && setup->active) {
            // The traced radiance cache of orders 3+ (docs/wkb.md), from the VRL light pass.
            const auto start = std::chrono::steady_clock::now();
            vrl::Orders3Options o;
            o.paths = rs.wkbOrders3Paths;  // 0: adaptive, up to the cap
            o.maxPaths = vrl::orders3PathCap(*ctx.scene);
            o.maxCells = vrl::orders3GridCells(ctx);
            o.seed = rs.seed;
            o.firstOrder = setup->cachedOrder2 ? 1 : 2;
            // Per-light layers where a light's AOV is in the film (setupFilm's rule).
            const auto& wanted = ctx.scene->output.aovs;
            o.perLightAovs.assign(ctx.lights.size(), 0);
            for (size_t i = 0; i < ctx.lights.size(); ++i)
                o.perLightAovs[i] = !options.outputAovsOnly || wanted.empty() ||
                                    std::find(wanted.begin(), wanted.end(), ctx.lights[i].aov) != wanted.end();
            vrl::Orders3Report report;
            orders3 = vrl::traceOrders3(ctx, o, &report);
            stats.orders3Cells = report.cells;
            stats.orders3SkinCells = report.skinCells;
            stats.orders3FocusRadius = report.aimedAtView ? report.focusRadius : 0.0f;
            stats.orders3Paths = report.paths;
            stats.orders3MaxPaths = report.adaptive ? o.maxPaths : 0;
            stats.orders3Noise = report.noiseMeasured;
            stats.orders3NoisePaths = report.noisePaths;
            stats.orders3Blurred = report.blurred;
            stats.orders3FirstOrder = o.firstOrder + 1;
            stats.addStage(setup->cachedOrder2 ? "orders 2+ light paths" : "orders 3+ light paths",
                           std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count());
        }
        return std::make_unique<wkb::WkbIntegrator>(ctx, plan, stats, std::move(orders3));
    };
    return e;
}

IntegratorEntry pathtraceEntry()
{
    IntegratorEntry e;
    e.traits = pathtraceTraits();
    e.create = [](const RenderContext& ctx, const RenderPlan&, const RenderOptions& options,
                  RenderStats&) -> std::unique_ptr<Integrator> {
        return std::make_unique<PathtraceIntegrator>(ctx, options.pathtrace);
    };
    return e;
}

IntegratorEntry vrlEntry()
{
    IntegratorEntry e;
    e.traits = vrlTraits();
    e.create = [](const RenderContext& ctx, const RenderPlan&, const RenderOptions& options,
                  RenderStats&) -> std::unique_ptr<Integrator> {
        return std::make_unique<VrlIntegrator>(ctx, options.pathtrace);
    };
    return e;
}

}  // namespace

const IntegratorEntry& integratorEntry(Method method)
{
    static const IntegratorEntry entries[] = {singleEntry(), wkbEntry(), pathtraceEntry(), vrlEntry()};
    for (const IntegratorEntry& e : entries)
        if (e.traits.method == method)
            return e;
    throw std::logic_error("no integrator registered for method " + std::string(methodName(method)));
}

}  // namespace nimbus
