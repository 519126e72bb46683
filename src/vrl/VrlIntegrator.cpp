#include "VrlIntegrator.h"

#include "../../kernels/shared/camera.h"
#include "../../kernels/shared/filter.h"
#include "../../kernels/shared/holdoutdepth.h"
#include "../core/Error.h"
#include "../core/Log.h"
#include "../pathtracer/PathtraceScene.h"
#include "../pathtracer/PathtraceState.h"
#include "../render/FilmLayout.h"
#include "../scene/KernelScene.h"
#include "SampleAllocation.h"
#include "VrlCamera.h"
#include "VrlLightPass.h"
#include "VrlMedium.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <utility>
#include <vector>

namespace nimbus {

namespace {

using Clock = std::chrono::steady_clock;

double secondsBetween(Clock::time_point a, Clock::time_point b)
{
    return std::chrono::duration<double>(b - a).count();
}

constexpr long long kMinNoiseTargetSpp = 64;  // the path tracer's

// An iteration's shutter time in [0, 1) (velocity blur): the base-2 radical inverse of its index,
// rotated by the seed (Cranley-Patterson), so that any run of 2^k iterations covers the shutter
// in 2^k strata, and sample splits, keyed by the global index, stay disjoint parts of one sequence.
float shutterTime(nb_uint seed, nb_uint iteration)
{
    nb_uint bits = iteration;
    bits = (bits << 16) | (bits >> 16);
    bits = ((bits & 0x00ff00ffu) << 8) | ((bits & 0xff00ff00u) >> 8);
    bits = ((bits & 0x0f0f0f0fu) << 4) | ((bits & 0xf0f0f0f0u) >> 4);
    bits = ((bits & 0x33333333u) << 2) | ((bits & 0xccccccccu) >> 2);
    bits = ((bits & 0x55555555u) << 1) | ((bits & 0xaaaaaaaau) >> 1);
    const double u = double(bits) / 4294967296.0 + double(nbPcgHash(seed ^ 0x7368757du)) / 4294967296.0;
    return std::min(float(u - std::floor(u)), 0x1.fffffep-1f);
}
// Streams of the extra camera paths, keyed apart from the first (the path tracer's stream). The
// key of path k is hashed before it meets the seed: seed ^ (key + k) would give seeds s and s'
// the same stream wherever s ^ k = s' ^ k', so renders with nearby seeds were correlated.
constexpr nb_uint kCameraStreamKey = 0x63616d00u;
nb_uint cameraStreamSeed(nb_uint seed, int k)
{
    return k == 0 ? seed : nbPcgHash(seed ^ nbPcgHash(kCameraStreamKey + nb_uint(k)));
}

// The pilot of SampleAllocation.h: kPilotIterations iterations on at most about kPilotPixels
// pixels (a lattice over the crop), each pixel with kPilotCameraPaths camera paths, on streams
// keyed apart from the render's.
constexpr int kPilotIterations = 4;
constexpr int kPilotPixels = 1024;
constexpr int kPilotCameraPaths = 4;
constexpr nb_uint kPilotStreamKey = 0x70696c6fu;
// A gather's joint sample in VrlMedium's work units (density reads): 6 for the advanced
// distribution (17 phase evaluations and its arc's table), 1 for the simple one's closed forms.
// Set by hand, not fitted; checked: with it the work model predicts the ratio of render times at
// two camera-path counts within about 10% on haze_lamp and medium_sphere (docs/vrl.md). An error
// here moves K by its square root.
double jointSampleWork(vrl::JointKind kind)
{
    return kind == vrl::JointKind::Simple ? 1.0 : 6.0;
}
// The light pass per VRL, shared by every pixel (its free flights run on TBB's threads, which the
// work counter does not see): a few majorant segments and density reads.
constexpr double kLightPassWorkPerVrl = 4.0;

// The joint distribution a scene asks for: "auto" is the advanced one where some phase function
// is anisotropic (Oppitz 7.3.2 gains nothing over 7.3.1 for g = 0 and costs 17 phase evaluations).
vrl::JointKind jointKind(const Scene& scene)
{
    switch (scene.render.vrlSampling) {
    case VrlSampling::Simple: return vrl::JointKind::Simple;
    case VrlSampling::Advanced: return vrl::JointKind::Advanced;
    case VrlSampling::Auto: break;
    }
    for (const Volume& v : scene.volumes) {
        const NbPhase p = v.medium.phase;
        if (p.g != 0.0f || (p.blend > 0.0f && p.g2 != 0.0f))
            return vrl::JointKind::Advanced;
    }
    return vrl::JointKind::Simple;
}

// The camera rays of a render: a pixel's ray on the stream `rng` was started on, the filter's
// jitter and the camera's time drawn from it as the path tracer draws them.
struct CameraRays {
    NbCamera cam;
    int filterType = 0;
    float filterWidth = 0;
    int width = 0, height = 0;
    const PathtraceScene* ps = nullptr;
    bool moves = false;  // the iteration's time rather than the sample's (VrlMedium.h)

    // o, d and tCamera: where a holdout (geometry or the depth map) ends the ray (INFINITY: none).
    void ray(int px, int py, float iterationTime, NbRng& rng, float3& o, float3& d, float& tCamera) const
    {
        const float jx = nbFilterSample(filterType, filterWidth, nbRngNext(&rng));
        const float jy = nbFilterSample(filterType, filterWidth, nbRngNext(&rng));
        const float cameraTime = nbRngNext(&rng);
        const float time = moves ? iterationTime : cameraTime;
        const float sx = float(px) + 0.5f + jx, sy = float(py) + 0.5f + jy;
        nbCameraRay(cam, sx, sy, width, height, time, &o, &d);
        tCamera = NB_INF;
        if (ps->holdouts)
            tCamera = nbGeomTrace(ps->geometry.nodes.data(), ps->geometry.prims.data(), ps->geometry.scene, o, d, 0.0f,
                                  NB_INF, NB_GEOM_HOLDOUT, 0);
        if (!ps->holdoutDepth.empty()) {
            const float z = nbHoldoutDepthAt(ps->holdoutDepth.data(), ps->holdoutDepthWidth, ps->holdoutDepthHeight,
                                             ps->holdoutDepthScale[0], ps->holdoutDepthScale[1], sx, sy);
            const float cosAxis = dot(d, nbCameraViewAxis(cam, time));
            if (z < NB_INF && cosAxis > 0.0f)
                tCamera = std::fmin(tCamera, z / cosAxis);
        }
    }
};

void clearSample(vrl::CameraSample& s, size_t lights)
{
    for (float3& L : s.L)
        L = make_float3(0, 0, 0);
    s.perLight.assign(lights, make_float3(0, 0, 0));
}

// The pilot of SampleAllocation.h on the crop of `film`. placeAt(time) puts moving lights and
// media at an iteration's shutter time (serially, between iterations).
vrl::PilotMeasure measurePilot(const Scene& scene, const Film& film, const CameraRays& rays,
                               const vrl::LightPass& lightPass, vrl::CameraSetup setup,
                               const std::function<void(float)>& placeAt)
{
    const int cropWidth = film.x1 - film.x0, cropHeight = film.y1 - film.y0;
    const double pixelCount = double(cropWidth) * double(cropHeight);
    const int stride = std::max(1, int(std::ceil(std::sqrt(pixelCount / kPilotPixels))));
    std::vector<std::pair<int, int>> pixels;
    for (int y = stride / 2; y < cropHeight; y += stride)
        for (int x = stride / 2; x < cropWidth; x += stride)
            pixels.emplace_back(film.x0 + x, film.y0 + y);
    const size_t n = pixels.size();
    struct Sample {
        double camera[kPilotCameraPaths];  // each camera path's L0 + L1 (channel average)
        double rest;                       // L2plus: the gathers and the path technique
        long long cameraWork, restWork;
    };
    std::vector<Sample> samples(n * kPilotIterations);
    const nb_uint seed = nbPcgHash(scene.render.seed ^ kPilotStreamKey);
    const size_t lights = setup.ps->lights.size();
    double vrlCount = 0;  // per iteration
    for (int j = 0; j < kPilotIterations; ++j) {
        const float iterationTime = shutterTime(seed, nb_uint(j));
        placeAt(iterationTime);
        const std::vector<vrl::Vrl> vrls = lightPass.trace(seed, nb_uint(j), scene.render.vrlPaths);
        vrlCount += double(vrls.size()) / kPilotIterations;
        setup.mis.setIteration(vrls);
        tbb::parallel_for(tbb::blocked_range<size_t>(0, n, 4), [&](const tbb::blocked_range<size_t>& r) {
            vrl::CameraSample path, sum;
            for (size_t i = r.begin(); i != r.end(); ++i) {
                const auto [px, py] = pixels[i];
                const nb_uint pixelIndex = nb_uint(py) * nb_uint(film.width) + nb_uint(px);
                Sample& out = samples[size_t(j) * n + i];
                out = Sample{};
                for (int k = 0; k < kPilotCameraPaths; ++k) {
                    NbRng rng = nbRngStart(cameraStreamSeed(seed, k), pixelIndex, nb_uint(j));
                    float3 o, d;
                    float tCamera;
                    rays.ray(px, py, iterationTime, rng, o, d, tCamera);
                    vrl::setWorkCounter(&out.cameraWork);
                    vrl::traceCameraPath(setup, o, d, tCamera, rng, path);
                    out.camera[k] = nbAverage(path.L[0] + path.L[1] + path.L[2]);
                    if (k == 0) {
                        vrl::setWorkCounter(&out.restWork);
                        clearSample(sum, lights);
                        vrl::gatherVrls(setup, o, d, tCamera, vrls, rng, sum);
                        vrl::gatherPaths(setup, o, d, tCamera, path, rng, sum);
                        out.rest = nbAverage(sum.L[2]);
                    }
                    vrl::setWorkCounter(nullptr);
                }
            }
        });
    }

    // Each pixel's value (its pilot mean) and nimbus compare's eps from the image's mean.
    std::vector<double> value(n, 0.0);
    double imageMean = 0;
    for (size_t i = 0; i < n; ++i) {
        for (int j = 0; j < kPilotIterations; ++j) {
            const Sample& s = samples[size_t(j) * n + i];
            double camera = 0;
            for (double c : s.camera)
                camera += c / kPilotCameraPaths;
            value[i] += (camera + s.rest) / kPilotIterations;
        }
        imageMean += value[i] / double(n);
    }
    const double eps = (0.1 * imageMean) * (0.1 * imageMean);
    vrl::PilotMeasure m;
    if (!(n > 0) || !(eps > 0.0) || !std::isfinite(eps))
        return m;  // nothing to weigh: chooseCameraPaths's fallback
    for (size_t i = 0; i < n; ++i) {
        const double norm = value[i] * value[i] + eps;
        double restSum = 0, restSquares = 0;
        for (int j = 0; j < kPilotIterations; ++j) {
            const Sample& s = samples[size_t(j) * n + i];
            double sum = 0, squares = 0;
            for (double c : s.camera)
                sum += c, squares += c * c;
            m.cameraVariance += (squares - sum * sum / kPilotCameraPaths) / (kPilotCameraPaths - 1) / norm;
            restSum += s.rest;
            restSquares += s.rest * s.rest;
            m.cameraWork += double(s.cameraWork);
            m.restWork += double(s.restWork);
        }
        m.restVariance += (restSquares - restSum * restSum / kPilotIterations) / (kPilotIterations - 1) / norm;
    }
    const double taken = double(n) * kPilotIterations;
    m.cameraVariance /= taken;
    m.restVariance /= double(n);
    m.cameraWork /= taken * kPilotCameraPaths;
    m.restWork =
        m.restWork / taken + jointSampleWork(setup.kind) * vrlCount + kLightPassWorkPerVrl * vrlCount / pixelCount;
    return m;
}

}  // namespace

IntegratorTraits vrlTraits()
{
    IntegratorTraits t;
    t.method = Method::Vrl;
    t.terms = {"L0", "L1", "L2plus"};
    t.dataAovs = {"variance"};
    t.shadowMaps = false;
    return t;
}

void renderVrl(const RenderContext& ctx, Film& film, const RenderControl& options, const PathtraceOptions& pt)
{
    if (!ctx.scene)
        throw Error("vrl: the render context has no scene");
    const Scene& scene = *ctx.scene;
    if (film.aovs.empty())
        setupFilm(film, scene, vrlTraits());
    const int cropWidth = film.x1 - film.x0, cropHeight = film.y1 - film.y0;
    const long long pixelCount = (long long)std::max(0, cropWidth) * std::max(0, cropHeight);
    if (pixelCount == 0)
        return;

    // Not const: lights moving within the shutter are placed at each iteration's time below.
    PathtraceScene ps = buildPathtraceScene(ctx);
    const std::vector<NbLight> lightsAtFrame = ps.lights;
    const bool moves = ps.velocity || ps.motion || ps.lightMotion;
    vrl::VrlMedium medium(ps);
    const int stride = NB_ACC_STRIDE(int(ps.lights.size()));
    std::vector<std::string> lightAovs;
    for (int entry : ps.lightEntry)
        lightAovs.push_back(ctx.lights[size_t(entry)].aov);
    if (pt.keepState)
        addStateAovs(film, lightAovs);
    const bool split = pt.sampleEnd > 0;
    if (split && (pt.sampleBegin < 0 || pt.sampleEnd <= pt.sampleBegin || pt.sampleEnd > 0x7fffffffLL))
        throw Error("vrl: sample range [" + std::to_string(pt.sampleBegin) + ", " + std::to_string(pt.sampleEnd) +
                    ") is empty or beyond 2^31 - 1");
    const long long first = split ? pt.sampleBegin : 0;
    std::vector<float> acc(size_t(pixelCount) * size_t(stride), 0.0f);
    if (pt.resumeFrom) {
        const Film& from = *pt.resumeFrom;
        if (from.x0 != film.x0 || from.x1 != film.x1 || from.y0 != film.y0 || from.y1 != film.y1 ||
            from.width != film.width || from.height != film.height)
            throw Error("vrl: the checkpoint's data window differs from the render's");
        if (!readState(from, lightAovs, acc))
            throw Error("vrl: the checkpoint lacks the running estimate (state AOVs) of this scene's lights");
        if (pt.resumeSamples < 0)
            throw Error("vrl: the checkpoint's sample count is negative");
    }

    const vrl::LightPass lightPass(ctx, ps, medium, scene.render.maxDepth);
    vrl::CameraSetup setup;
    setup.ps = &ps;
    setup.medium = &medium;
    setup.background = make_float3(ctx.background.x, ctx.background.y, ctx.background.z);
    setup.maxDepth = scene.render.maxDepth;
    setup.kind = jointKind(scene);
    setup.cameraPhase = medium.dominantPhase();
    setup.mis = vrl::BeamPathMis(ps, medium, lightPass, setup.kind, setup.cameraPhase, scene.render.vrlPaths);
    CameraRays rays;
    rays.cam = makeNbCamera(scene.camera);
    rays.filterType = nbFilterType(scene.render.pixelFilter);
    rays.filterWidth = scene.render.filterWidth;
    rays.width = film.width;
    rays.height = film.height;
    rays.ps = &ps;
    rays.moves = moves;
    // Motion blur (velocity, volume transforms, lights): one shutter time per iteration, for its
    // light paths and all its camera paths (VrlMedium.h); iterations average over the shutter.
    // Moving lights are placed at that time between iterations, so that the light pass and the
    // camera paths' next-event estimation both see them there.
    const auto placeAt = [&](float iterationTime) {
        if (!moves)
            return;
        const float seconds = ctx.volumes.shutterSeconds(iterationTime);
        medium.setShutterSeconds(seconds);
        for (size_t i = 0; i < ps.lights.size(); ++i)
            if (lightsAtFrame[i].motion[1] > 0)
                ps.lights[i] = nbLightAt(lightsAtFrame[i], ps.majorants.data() + lightsAtFrame[i].motion[0],
                                         lightsAtFrame[i].motion[1], seconds);
    };
    // Camera paths per pixel and iteration (SampleAllocation.h), from a pilot that every render of
    // this scene and seed repeats the same way. Where it finds nothing to weigh, as many camera
    // paths as light paths (the rule before the pilot).
    const int cameraPaths = vrl::chooseCameraPaths(measurePilot(scene, film, rays, lightPass, setup, placeAt),
                                                   std::max(1, scene.render.vrlPaths));

    const double timeLimit = scene.render.timeLimit;
    const double noiseTarget = split || scene.render.spp > 0 ? 0.0 : scene.render.noiseTarget;
    const long long sppTarget = split                  ? pt.sampleEnd - pt.sampleBegin
                                : scene.render.spp > 0 ? scene.render.spp
                                                       : (timeLimit > 0 || noiseTarget > 0 ? 0 : 1);
    const int paths = scene.render.vrlPaths;
    std::atomic<long long> bad{0};
    long long vrlCount = 0;
    double noise = INFINITY;

    const auto start = Clock::now();
    auto lastCheckpoint = start;
    long long done = pt.resumeFrom ? pt.resumeSamples : 0;
    const double startSeconds = pt.resumeFrom ? std::max(0.0, pt.resumeSeconds) : 0.0;
    int passes = 0;
    for (;;) {
        if (sppTarget > 0 && done >= sppTarget)
            break;
        if (first + done >= 0xffffffffLL)
            break;  // the RNG's sample index is 32 bits
        const nb_uint sampleIndex = nb_uint(first + done);
        const float iterationTime = shutterTime(scene.render.seed, sampleIndex);
        placeAt(iterationTime);
        const std::vector<vrl::Vrl> vrls = lightPass.trace(scene.render.seed, sampleIndex, paths);
        vrlCount += (long long)vrls.size();
        setup.mis.setIteration(vrls);
        const float inv = 1.0f / float(sampleIndex - nb_uint(first) + 1u);
        tbb::parallel_for(
            tbb::blocked_range<long long>(0, pixelCount, 16), [&](const tbb::blocked_range<long long>& r) {
                vrl::CameraSample cs, one;
                for (long long gid = r.begin(); gid != r.end(); ++gid) {
                    if (ctx.stop.raised())
                        return;
                    const int px = film.x0 + int(gid % cropWidth), py = film.y0 + int(gid / cropWidth);
                    const nb_uint pixelIndex = nb_uint(py) * nb_uint(film.width) + nb_uint(px);
                    // K camera paths for L0 and L1 (the first is the path tracer's own sample), the
                    // first one's ray also gathering from every VRL (SampleAllocation.h).
                    clearSample(cs, ps.lights.size());
                    cs.transmittance = cs.depth = cs.hasDepth = 0;
                    const float share = 1.0f / float(cameraPaths);
                    for (int k = 0; k < cameraPaths; ++k) {
                        NbRng rng = nbRngStart(cameraStreamSeed(scene.render.seed, k), pixelIndex, sampleIndex);
                        float3 o, d;
                        float tCamera;
                        rays.ray(px, py, iterationTime, rng, o, d, tCamera);
                        vrl::traceCameraPath(setup, o, d, tCamera, rng, one);
                        for (int t = 0; t < 3; ++t)
                            cs.L[t] += one.L[t] * share;
                        cs.transmittance += one.transmittance * share;
                        cs.depth += one.depth * one.hasDepth * share;
                        cs.hasDepth += one.hasDepth * share;
                        for (size_t i = 0; i < cs.perLight.size(); ++i)
                            cs.perLight[i] += one.perLight[i] * share;
                        if (k == 0) {
                            vrl::gatherVrls(setup, o, d, tCamera, vrls, rng, cs);
                            vrl::gatherPaths(setup, o, d, tCamera, one, rng, cs);
                        }
                    }
                    float3 beauty = cs.L[0] + cs.L[1] + cs.L[2];
                    float y = nbAverage(beauty);
                    if (!std::isfinite(y)) {  // dropped and counted, as the path tracer does
                        ++bad;
                        clearSample(cs, ps.lights.size());
                        y = 0;
                    }
                    float* a = acc.data() + size_t(gid) * size_t(stride);
                    for (int k = 0; k < 3; ++k) {
                        a[3 * k + 0] += (cs.L[k].x - a[3 * k + 0]) * inv;
                        a[3 * k + 1] += (cs.L[k].y - a[3 * k + 1]) * inv;
                        a[3 * k + 2] += (cs.L[k].z - a[3 * k + 2]) * inv;
                    }
                    a[NB_ACC_TRANSMITTANCE] += (cs.transmittance - a[NB_ACC_TRANSMITTANCE]) * inv;
                    a[NB_ACC_DEPTH_SUM] += (cs.depth - a[NB_ACC_DEPTH_SUM]) * inv;  // depth x hit, averaged
                    a[NB_ACC_DEPTH_HITS] += (cs.hasDepth - a[NB_ACC_DEPTH_HITS]) * inv;
                    const float delta = y - a[NB_ACC_MEAN_Y];
                    a[NB_ACC_MEAN_Y] += delta * inv;
                    a[NB_ACC_M2_Y] += delta * (y - a[NB_ACC_MEAN_Y]);
                    for (size_t i = 0; i < cs.perLight.size(); ++i) {
                        float* q = a + NB_ACC_LIGHTS + 3 * i;
                        q[0] += (cs.perLight[i].x - q[0]) * inv;
                        q[1] += (cs.perLight[i].y - q[1]) * inv;
                        q[2] += (cs.perLight[i].z - q[2]) * inv;
                    }
                }
            });
        if (ctx.stop.raised() || (options.cancel && options.cancel->load()))
            throw Cancelled();
        const auto now = Clock::now();
        ++done;
        ++passes;
        const double elapsed = startSeconds + secondsBetween(start, now);
        bool converged = false;
        if (noiseTarget > 0 && done >= kMinNoiseTargetSpp) {
            noise = stateNoiseRelMse(acc, stride, done);
            converged = noise <= noiseTarget;
        }
        if (options.progress) {
            float fraction = sppTarget > 0 ? float(double(done) / double(sppTarget)) : 0.0f;
            if (noiseTarget > 0 && std::isfinite(noise))
                fraction = std::max(fraction, float(std::min(1.0, noiseTarget / noise)));
            if (timeLimit > 0)
                fraction = std::max(fraction, float(std::min(1.0, elapsed / timeLimit)));
            if (!options.progress(std::min(fraction, 1.0f)))
                throw Cancelled();
        }
        if (converged || (timeLimit > 0 && elapsed >= timeLimit))
            break;
        if (pt.checkpointSeconds > 0 && pt.onCheckpoint &&
            secondsBetween(lastCheckpoint, now) >= pt.checkpointSeconds && !(sppTarget > 0 && done >= sppTarget)) {
            resolveState(acc, done, lightAovs, film);
            film.set("pathtrace_spp", std::to_string(done));
            if (split)
                film.set("sample_start", int(first));
            pt.onCheckpoint(film);
            lastCheckpoint = Clock::now();
        }
    }
    resolveState(acc, done, lightAovs, film);
    const double renderSeconds = secondsBetween(start, Clock::now());
    if (bad > 0)
        logWarning("vrl: " + std::to_string(bad.load()) + " non-finite samples dropped");
    // The samples-per-pixel key the progressive machinery reads (checkpoints, resume, merge,
    // compare) is the path tracer's: one iteration is one sample per pixel.
    film.set("pathtrace_spp", std::to_string(done));
    film.set("vrl_paths", paths);
    film.set("vrl_camera_paths", cameraPaths);
    film.set("vrl_sampling", std::string(setup.kind == vrl::JointKind::Simple ? "simple" : "advanced"));
    if (split)
        film.set("sample_start", int(first));
    if (pt.stats) {
        PathtraceStats& s = *pt.stats;
        s.samplesPerPixel = done;
        s.pathSamples = done * pixelCount;
        s.renderSeconds = renderSeconds;
        s.passes = passes;
        s.badSamples = bad;
        s.noiseRelMse = noiseTarget > 0 ? noise : 0;
        s.device = "cpu (TBB), " + std::to_string(vrlCount) + " VRLs, " + std::to_string(cameraPaths) +
                   " camera paths per pixel and iteration";
    }
}

}  // namespace nimbus
