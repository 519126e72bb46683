#include "WkbIntegrator.h"

#include "../core/StepCount.h"

#include "LegendreSeries.h"
#include "../render/SphericalHarmonics.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

// The l-march (Tessendorf sec. 6.3.4, eq. 89; docs/wkb.md "the march").
//
// One shared step for RGB, per-channel weights. The march variable is lhat, the mean of the three
// channels' scattering lengths, and every stretch of the (l, s) table carries all three channels'
// l and absorption depth exactly. The quantities that change a lot between channels in real
// media, the attenuation e^{-tau_a} and the angular kernels R_j(l_c), are therefore evaluated per
// channel; only the quadrature points and the source placement and blur (geometric, and
// insensitive to the few percent by which b differs between channels in clouds and smoke) are
// shared. A per-channel march would triple the source lookups, the dominant cost, for no
// visible gain; a strongly chromatic b costs only quadrature accuracy here, never a bias in T.
//
// Steps. A node covers lhat -> lhat + l_step max(1, lhat) (equal steps in l, growing by l_step
// relative past l = 1, where the integrand varies on the scale of l), but at most half the
// current blur width (or half a light voxel) in distance, so the source never jumps a feature it
// can resolve. Per node: the weight T(0,s)(e^l - 1) integrated exactly over the node
// (weightIntegral), times sum_j p_j R_j(l) ... at the node's midpoint in l, times Lblur read
// where the placement model says.
//
// Medium sampling. While the blur is under a light voxel the stretches are jittered sub-steps of
// the density grid (exact coefficients). Past that, stretches grow with the nodes (half the blur
// width) and read the density from the light pyramid's channel 0, prefiltered to the stretch's
// length: the mip-mapped march Tessendorf describes ("the blur is used to accelerate ray
// marching"), which loses only structure finer than the stretch.

namespace nimbus::wkb {

namespace {

constexpr int kMaxNodes = 100000;
constexpr double kNodeSpatial = 0.5;  // node length, in blur widths (or light voxels)
// The march reads the density from the pyramid once the blur exceeds this many light voxels.
constexpr double kCoarseFrom = 0.5;
// Fine stretches are twice the L1 step: the table needs the integral of b over a node, and nodes
// are at least a light voxel (two density voxels) long; the L1 step resolves single scattering's
// shadows, which L2+ never sees unblurred.
constexpr double kFineStepScale = 2.0;
// Optical depth of a light voxel above which delta sources read E itself at small blur.
constexpr double kExactDepth = 0.5;
// Guaranteed progress of the l-march (issue 18, failure 3: with sigma * density at float's limit
// the take below became 0 and the loop spun forever). Each pass takes at least this fraction of
// its piece, and a node ends after kMaxPassesPerNode passes, whatever the numbers do. Neither
// binds in a medium within the extinction range (SceneValidate.h, kMaxExtinction): a node is
// a handful of pieces there.
constexpr double kMinTakeFraction = 1e-6;
constexpr int kMaxPassesPerNode = 1 << 20;

}  // namespace

struct WkbIntegrator::Piece {
    double len = 0.0;
    double b[3] = {0, 0, 0};
    double a[3] = {0, 0, 0};
    bool gap = false;
};

struct WkbIntegrator::Cursor {
    size_t span = 0;
    bool coarse = false;
    int fineN = 0, fineK = 0;
    double fineDt = 0.0;
    float jitter = 0.5f;
};

struct WkbIntegrator::Scratch {
    std::vector<Span> spans;
    ScatteringTable table;
    std::vector<float> phaseWeights;
    std::vector<double> pieceW, nodeW;  // per volume scattering weight: of the pending piece (1/m), of the node
    std::vector<float> channels;
    std::vector<double> coef, coefLights, pj, shY, sums;
    Piece pending;
    bool hasPending = false;
    double muLast = kMuMax;
    double sEntry = -1.0;
    float seconds = 0.0f;  // the ray's shutter time (velocity blur)
};

WkbIntegrator::WkbIntegrator(const RenderContext& ctx, const RenderPlan& plan, RenderStats& stats,
                             std::shared_ptr<const RadianceGrid> orders3)
    : mCtx(&ctx), mOrders3(std::move(orders3))
{
    const auto* setup = dynamic_cast<const WkbSetup*>(plan.integrator.get());
    if (!setup)
        throw std::logic_error("WkbIntegrator: the plan has no wkb part (plan it with planWkb)");
    mSetup = *setup;
    // Where the plan traces orders 3+ (SourcePlan::kernel false for the lights) and no cache came
    // (IntegratorRegistry's traceOrders3 makes none where its light pass has no path, the lights
    // carrying no power into the volumes), the lights' orders 3+ are zero, as they are then.
    mModel = mSetup.randomWalk ? PlacementModel::RandomWalk : PlacementModel::Straight;
    for (auto& v : ctx.volumes.volumes()) {
        mSigmaS.push_back(v->sigmaS());
        mSigmaA.push_back(fmax(v->sigmaT() - v->sigmaS(), splat(0.0f)));
        mPhase.push_back(v->medium.phase);
    }
    mLights.build(ctx, mSetup, stats);
    mEmission = std::make_unique<EmissionScatter>(ctx);
    if (mSetup.tracedOrder2)
        mOrder2 = std::make_unique<TracedOrder2>(ctx);
    mMinLightVoxel = 1e30f;
    for (const VolumeSetup& vs : mSetup.volumes)
        mMinLightVoxel = std::min(mMinLightVoxel, vs.lightVoxel);
    if (mSetup.volumes.empty())
        mMinLightVoxel = 1.0f;
    for (const SourcePlan& sp : mSetup.sources)
        if (sp.mode == SourceMode::Sh && sp.kernel)
            mMaxShOrder = std::max(mMaxShOrder, sp.order);
    mOrder2Outside = mOrder2 != nullptr || mSetup.cachedOrder2;
    // Where both of the lights' parts the kernel would give are traced, it is left with emission.
    mKernelSources = mSetup.kernelSources;
}

void WkbIntegrator::marchRays(int n, const float3* o, const float3* d, const float* tFar, const float* time,
                              NbRng* rng, CameraSample* out, float* perLight) const
{
    const size_t stride = 3 * mCtx->lights.size();
    const VolumeSet& vs = mCtx->volumes;
    // Velocity blur: each ray's shutter fraction as seconds after the frame's time.
    thread_local std::vector<float> seconds;
    const bool moving = mCtx->moving() && time;
    seconds.assign(size_t(n), 0.0f);
    if (moving)
        for (int i = 0; i < n; ++i)
            seconds[size_t(i)] = vs.shutterSeconds(time[i]);
    // L1 as `single` marches it, the rays together (eight at once where the medium and lights
    // allow, MarchEightRays.h); each ray draws from its own generator, so the order of the rays
    // leaves every draw as it was.
    // Where the radiance cache alone gives the lights' orders 2+ (or 3+ over the kernel's order 2),
    // L1's samples read it too (InScatterGrid.h): no second march of the ray.
    InScatterGrid grid;
    const bool fused = mOrders3 && !mOrder2 && !moving && mOrders3->view(grid);
    thread_local std::vector<float3> gridL;  // [ray][layer]
    thread_local std::vector<unsigned char> gridRead;
    gridL.resize(size_t(n) * size_t(fused ? grid.layers : 1));
    gridRead.resize(size_t(n));
    marchSingleRays(*mCtx, n, o, d, rng, out, perLight, tFar, moving ? seconds.data() : nullptr,
                    fused ? &grid : nullptr, gridL.data(), gridRead.data());
    for (int i = 0; i < n; ++i) {
        float* pl = perLight + stride * size_t(i);
        const float t = tFar ? tFar[i] : INFINITY;
        mEmission->add(o[i], d[i], rng[i], out[i], t, seconds[size_t(i)]);  // single's L1 of emission, the same draws
        march(o[i], d[i], rng[i], out[i], pl, t, seconds[size_t(i)],
              fused && gridRead[size_t(i)] ? &gridL[size_t(i) * size_t(grid.layers)] : nullptr);
    }
}

bool WkbIntegrator::nextPiece(Cursor& cur, Scratch& sc, float3 o, float3 d, double maxLen, double sigmaMarch) const
{
    const VolumeSet& vs = mCtx->volumes;
    const double s = sc.table.back().s;
    Piece& p = sc.pending;
    p = Piece();
    while (cur.span < sc.spans.size()) {
        const Span& span = sc.spans[cur.span];
        const double t0 = span.t0, t1 = span.t1;
        const double eps = 1e-7 * std::max(1.0, std::fabs(t1));
        if (s >= t1 - eps) {
            ++cur.span;
            cur.fineN = 0;
            continue;
        }
        if (s < t0 - eps) {
            p.gap = true;
            p.len = t0 - s;
            return true;
        }
        if (!cur.coarse && sigmaMarch >= kCoarseFrom * mMinLightVoxel)
            cur.coarse = true;
        if (!cur.coarse) {
            if (cur.fineN == 0) {
                // At least a hundredth of the smallest voxel (render.step reaches denormals).
                cur.fineN = stepCount(t1 - t0, std::max(kFineStepScale * span.step,
                                                        0.01 * double(mCtx->volumes.minVoxelSize())));
                cur.fineDt = (t1 - t0) / cur.fineN;
                cur.fineK = std::min(cur.fineN - 1, std::max(0, int(std::floor((s - t0) / cur.fineDt))));
            }
            const double a = t0 + cur.fineK * cur.fineDt;
            const double end = cur.fineK + 1 >= cur.fineN ? t1 : a + cur.fineDt;
            if (++cur.fineK >= cur.fineN) {
                ++cur.span;
                cur.fineN = 0;
            }
            if (end <= s + eps)
                continue;
            MediumSample m = vs.sampleAt(sc.seconds, o + d * float(a + cur.jitter * cur.fineDt), sc.phaseWeights.data());
            p.len = end - s;
            const Rgb sa = fmax(m.sigma_t - m.sigma_s, splat(0.0f));
            p.b[0] = m.sigma_s.x, p.b[1] = m.sigma_s.y, p.b[2] = m.sigma_s.z;
            p.a[0] = sa.x, p.a[1] = sa.y, p.a[2] = sa.z;
            for (size_t v = 0; v < sc.pieceW.size(); ++v)
                sc.pieceW[v] = sc.phaseWeights[v];
            return true;
        }
        // Coarse: one density sample per stretch, from the pyramid prefiltered to the stretch's
        // own length (the Gaussian of a box that long, len / sqrt(12)): the table needs the
        // integral of b along the stretch. (Reading it at the source's blur instead would average
        // the density over a ball as wide as the blur, and in a ball-shaped cloud lose half its l.)
        p.len = std::min(maxLen, t1 - s);
        // Moving volumes: the pyramid is the frame's, read where the matter was then.
        const float3 x = vs.lightPointAt(sc.seconds, o + d * float(s + 0.5 * p.len));
        const float sigmaStretch = float(p.len * 0.28867513459481287);
        for (size_t v = 0; v < mSetup.volumes.size(); ++v) {
            const VolumeSetup& vsu = mSetup.volumes[v];
            const VolumeData& vol = *vs.volumes()[v];
            float rho = 0.0f;
            const float3 pl = (vol.indexFromWorld.point(x) - vsu.origin) * (1.0f / float(vsu.factor));
            mLights.pyramid(v).fetch(pl, sigmaStretch / vsu.lightVoxel, 0, 1, 1.0f, &rho);
            rho = std::max(rho, 0.0f);
            for (int c = 0; c < 3; ++c) {
                p.b[c] += double(component(mSigmaS[v], c)) * rho;
                p.a[c] += double(component(mSigmaA[v], c)) * rho;
            }
            sc.pieceW[v] = double(nbAverage(mSigmaS[v])) * rho;
        }
        return true;
    }
    return false;
}

bool WkbIntegrator::readSources(float3 x, double sigma, float* out) const
{
    const int C = mSetup.channels;
    std::fill(out, out + C, 0.0f);
    const auto& vols = mCtx->volumes.volumes();
    for (size_t v = 0; v < mSetup.volumes.size(); ++v) {
        const VolumeSetup& vs = mSetup.volumes[v];
        if (!vs.l2plus)
            continue;
        // Weight each volume's density by its mean scattering coefficient: the channels then
        // sum to b and b * source, and their ratio is the b-weighted source (docs/wkb.md).
        const float3 pl = (vols[v]->indexFromWorld.point(x) - vs.origin) * (1.0f / float(vs.factor));
        mLights.pyramid(v).fetch(pl, float(sigma) / vs.lightVoxel, 0, C, nbAverage(mSigmaS[v]), out);
    }
    return out[0] > 1e-30f;
}

void WkbIntegrator::evaluateNode(Scratch& sc, float3 o, float3 d, const TableEntry& e0, const TableEntry& e1, double* L,
                                 double& remaining) const
{
    const ScatteringTable& table = sc.table;
    // The node's quadrature point: the centroid in l of its weight, not its midpoint. Near l = 0
    // the weight grows like l, its centroid sits at 2/3 of the node, and reading the source (which
    // fades into the medium) at the midpoint would bias L2+ by the step size. Two-point Gauss on
    // the channels' mean weight; exact for a weight linear across the node.
    double lq;
    {
        const double la = e0.lhat, dl = e1.lhat - e0.lhat;
        const double dta = (e1.tauA[0] + e1.tauA[1] + e1.tauA[2] - e0.tauA[0] - e0.tauA[1] - e0.tauA[2]) / 3.0;
        const double alpha = dl > 0.0 ? std::max(dta, 0.0) / dl : 0.0;  // 1/omega0 - 1 over the node
        const double u1 = dl * (0.5 - 0.28867513459481287), u2 = dl * (0.5 + 0.28867513459481287);
        const double w1 = std::exp(-alpha * u1) * -std::expm1(-(la + u1));
        const double w2 = std::exp(-alpha * u2) * -std::expm1(-(la + u2));
        lq = w1 + w2 > 0.0 ? la + (u1 * w1 + u2 * w2) / (w1 + w2) : la + 0.5 * dl;
    }
    const TableEntry m = table.at(table.sAt(lq));

    // Phase moments of the node: the scattering-weighted mixture of the volumes it crossed.
    double wsum = 0.0, gmax = 0.0;
    for (size_t v = 0; v < sc.nodeW.size(); ++v) {
        wsum += sc.nodeW[v];
        if (sc.nodeW[v] > 0.0)
            gmax = std::max(gmax, nbPhaseMomentBound(mPhase[v]));
    }
    if (!(wsum > 0.0))
        return;
    double p1 = 0.0;
    for (size_t v = 0; v < sc.nodeW.size(); ++v)
        if (sc.nodeW[v] > 0.0)
            p1 += sc.nodeW[v] * nbPhaseMeanCos(mPhase[v]);
    p1 /= wsum;
    const double mu = gaussianMu(p1);
    sc.muLast = mu;

    // Weight per channel, exact over the node with the node's mean albedo.
    double W[3];
    double lmin = m.l[0];
    const bool greyStep = e1.l[0] == e1.l[1] && e1.l[1] == e1.l[2] && e1.tauA[0] == e1.tauA[1] &&
                          e1.tauA[1] == e1.tauA[2] && e0.l[0] == e0.l[1] && e0.l[1] == e0.l[2] &&
                          e0.tauA[0] == e0.tauA[1] && e0.tauA[1] == e0.tauA[2];
    for (int c = 0; c < 3; ++c) {
        lmin = std::min(lmin, m.l[c]);
        if (c > 0 && greyStep) {
            W[c] = W[0];
            continue;
        }
        const double dl = e1.l[c] - e0.l[c], dta = e1.tauA[c] - e0.tauA[c];
        const double omega = dl > 0.0 ? dl / (dl + std::max(dta, 0.0)) : 0.0;
        W[c] = weightIntegral(e0.l[c], e0.tauA[c], dl, omega);
    }
    const Truncation tr = truncateOrders(mSetup.kernel, lmin, mu, gmax, mSetup.tolerance, mSetup.orderCap);
    // The bound decreases with tau_a: the least absorbed channel bounds all three.
    const double tauAMin = std::min(e1.tauA[0], std::min(e1.tauA[1], e1.tauA[2]));
    remaining = remainingWeightBound(e1.lhat, tauAMin, mSetup.omegaMax) * tr.total / NB_INV_4PI_D;
    if (!(std::max(W[0], std::max(W[1], W[2])) > 0.0))
        return;

    // coef[c][j] = p_j R_j(l_c) at the node's quadrature point.
    const int J = tr.order;
    // p_j of the mixture: sum over volumes and lobes of weight * g^j, by running powers.
    sc.pj.assign(size_t(J) + 1, 0.0);
    for (size_t v = 0; v < sc.nodeW.size(); ++v) {
        if (!(sc.nodeW[v] > 0.0))
            continue;
        nbPhaseAddMoments(mPhase[v], sc.nodeW[v] / wsum, J, sc.pj.data());
    }
    sc.coef.resize(3 * (size_t(J) + 1));
    const bool grey = m.l[0] == m.l[1] && m.l[1] == m.l[2];
    for (int c = 0; c < 3; ++c) {
        double* k = sc.coef.data() + size_t(c) * (J + 1);
        if (c > 0 && grey) {
            std::copy(sc.coef.begin(), sc.coef.begin() + (J + 1), k);
            continue;
        }
        if (mSetup.kernel == KernelType::Gaussian) {
            const double q = std::exp(-muL(mu, m.l[c]));  // A_{j+1} / A_j = q^{j+1}
            double A = 1.0, qpow = 1.0;
            for (int j = 0; j <= J; ++j) {
                k[j] = sc.pj[j] * A;
                qpow *= q;
                A *= qpow;
            }
        } else {
            for (int j = 0; j <= J; ++j)
                k[j] = sc.pj[j] * exactRatio(sc.pj[j], m.l[c]);
        }
    }

    // The kernel's N = 1 term, the one further scattering (the lights' order 2): e^{-l} l p_j
    // against the weight's e^{-l}(e^l - 1), so R_j's share of it is l p_j / (e^l - 1)
    // (AngularKernel.h). For the Gaussian kernel the p_j of that term is the Gaussian phase's own,
    // e^{-mu j(j+1)/2} = A_j(0), so that orders 3+ vanish as l -> 0 in both kernels. With order 2
    // traced (TracedOrder2) the lights' kernel drops that term (R_j -> R_j - l p_j / (e^l - 1): orders
    // 3+); with orders 3+ traced (the radiance cache) and order 2 by the kernel it keeps that term
    // alone. Emission's sources keep every order (both traced parts follow the lights only).
    const bool splitLights = mOrder2Outside != (mOrders3 != nullptr);
    if (splitLights) {
        sc.coefLights.resize(sc.coef.size());
        for (int c = 0; c < 3; ++c) {
            const double l = m.l[c];
            const double share = l < 1e-12 ? 1.0 - 0.5 * l : l / std::expm1(l);  // l / (e^l - 1)
            const double* k = sc.coef.data() + size_t(c) * (J + 1);
            double* kl = sc.coefLights.data() + size_t(c) * (J + 1);
            for (int j = 0; j <= J; ++j) {
                const double pFirst =
                    mSetup.kernel == KernelType::Gaussian ? std::exp(-0.5 * mu * j * (j + 1)) : sc.pj[j];
                const double order2 = sc.pj[j] * share * pFirst;
                kl[j] = mOrder2 ? k[j] - order2 : order2;
            }
        }
    }

    // Where the source is read, and how blurred.
    PlacementInput in;
    in.table = &table;
    in.at = m;
    in.sEntry = sc.sEntry;
    in.mu = mu;
    in.g = p1;
    in.blurK = mSetup.blurK;
    const SourceRead src = placeSource(mModel, in);
    // Moving volumes: the light volumes are the frame's, read where the matter was then.
    const float3 x = mCtx->volumes.lightPointAt(sc.seconds, o + d * float(src.s));
    float* ch = sc.channels.data();
    const bool blurred = readSources(x, src.sigma, ch);
    // Below the light grid's own resolution, delta sources read L0 itself: E(x) from the deep
    // shadow map, the zero-blur end of the pyramid, blended into level 0 up to half a light voxel
    // (what level 0's voxel average and trilinear read amount to). In media thick per voxel the
    // short paths start within a fraction of a voxel of the ray, where only this sees the light.
    // Where a light voxel is optically thin (the node's mean extinction times its size under
    // kExactDepth) E varies little across it and level 0 already holds it: no lookup is spent.
    const double nodeLength = std::max(e1.s - e0.s, 1e-30);
    const double nodeDepth =
        (e1.lhat - e0.lhat + (e1.tauA[0] + e1.tauA[1] + e1.tauA[2] - e0.tauA[0] - e0.tauA[1] - e0.tauA[2]) / 3.0) /
        nodeLength * double(mMinLightVoxel);
    const double exactWeight =
        nodeDepth < kExactDepth ? 0.0 : std::max(0.0, 1.0 - src.sigma / (0.5 * double(mMinLightVoxel)));
    if (!blurred && !(exactWeight > 0.0))
        return;
    const double inv = blurred ? 1.0 / double(ch[0]) : 0.0;
    const float3 n = -d;  // the direction the light travels toward the camera

    for (size_t si = 0; si < mSetup.sources.size(); ++si) {
        const SourcePlan& sp = mSetup.sources[si];
        if (sp.mode == SourceMode::Skip || !sp.kernel)
            continue;  // traced order 2 and orders 3+ (the radiance cache) replace the lights' kernel
        const std::vector<double>& coef = splitLights && !sp.emission ? sc.coefLights : sc.coef;
        double S[3] = {0, 0, 0};
        if (sp.mode == SourceMode::Delta) {
            // Addition theorem: sum_m Y_jm(n) Y*_jm(N) = (2j+1)/(4 pi) P_j(n . N).
            const double x0 = std::max(-1.0, std::min(1.0, double(dot(n, LightVolumes::deltaDirection(sp, x)))));
            LegendreSeries P(x0);
            for (int j = 0; j <= J; ++j, P.advance()) {
                const double f = double(2 * j + 1) * NB_INV_4PI_D * P.value();
                for (int c = 0; c < 3; ++c)
                    S[c] += f * coef[size_t(c) * (J + 1) + j];
            }
            Rgb E = splat(0.0f);
            if (exactWeight > 0.0)
                E = mLights.deltaE(sp, si, x, 0.5f * mMinLightVoxel);
            for (int c = 0; c < 3; ++c) {
                double Eb = blurred ? double(ch[sp.offset + c]) * inv : double(component(E, c));
                S[c] *= exactWeight * double(component(E, c)) + (1.0 - exactWeight) * Eb;
            }
        } else if (blurred) {
            const int Jsh = std::min(J, sp.order);
            for (int j = 0; j <= Jsh; ++j)
                for (int mm = -j; mm <= j; ++mm) {
                    const int jm = shIndex(j, mm);
                    for (int c = 0; c < 3; ++c)
                        S[c] +=
                            coef[size_t(c) * (J + 1) + j] * sc.shY[jm] * double(ch[sp.offset + 3 * jm + c]) * inv;
                }
        }
        // A truncated order sum can ring below zero where the true angular distribution is small;
        // radiance cannot.
        for (int c = 0; c < 3; ++c)
            L[3 * si + c] += W[c] * std::max(0.0, S[c]);
    }
}

void WkbIntegrator::march(float3 o, float3 d, NbRng& rng, CameraSample& out, float* perLight, float tFar, float seconds,
                          const float3* orders3Read) const
{
    if (!mSetup.active)
        return;
    const ScatterPointSampler* marched = mOrder2 ? mOrder2->add(o, d, rng, out, perLight, tFar, seconds) : nullptr;
    if (mOrders3) {
        // The lights' orders 3+ from the traced radiance cache, projected toward the camera.
        // Each layer of the cache is one light's (its AOV gets it) or several lights' (L2plus only).
        // Over traced order 2's march of this ray where there is one (the same steps; where traced
        // order 2 found no scattering medium on the ray, orders 3+ are 0 too), else marched here.
        if (marched || !mOrder2 || mCtx->moving()) {
            thread_local std::vector<float3> layers;
            layers.resize(size_t(mOrders3->layers()));
            float3 read = make_float3(0, 0, 0);
            if (orders3Read)
                for (size_t k = 0; k < layers.size(); ++k) {
                    layers[k] = orders3Read[k];
                    read += orders3Read[k];
                }
            const float3 L3 = orders3Read ? read
                              : marched && !mCtx->moving()
                                  ? readOrders3(*mOrders3, *marched, o, d, layers.data())
                                  : marchOrders3(mCtx->volumes, *mOrders3, o, d, tFar, seconds, nbRngNext(&rng),
                                                 mCtx->scene->render.step, kOrders3StepScale, layers.data());
            out.L2plus += L3;
            for (int k = 0; k < mOrders3->layers(); ++k) {
                const int li = mOrders3->layerLight(k);
                if (li >= 0 && perLight) {
                    perLight[3 * li + 0] += layers[size_t(k)].x;
                    perLight[3 * li + 1] += layers[size_t(k)].y;
                    perLight[3 * li + 2] += layers[size_t(k)].z;
                }
            }
        }
        if (!mKernelSources)
            return;
    }
    thread_local Scratch sc;
    sc.seconds = seconds;
    const VolumeSet& vs = mCtx->volumes;
    const size_t nv = vs.volumes().size();
    const float jitter = nbRngNext(&rng);
    vs.spansAt(seconds, o, d, 0.0f, std::min(tFar, 1e30f), mCtx->scene->render.step, sc.spans);
    if (sc.spans.empty())
        return;
    sc.phaseWeights.assign(nv, 0.0f);
    sc.pieceW.assign(nv, 0.0);
    sc.nodeW.assign(nv, 0.0);
    sc.channels.assign(size_t(mSetup.channels), 0.0f);
    sc.sums.assign(3 * mSetup.sources.size(), 0.0);
    if (mMaxShOrder >= 0) {
        sc.shY.resize(size_t(shCount(mMaxShOrder)));
        shEvaluate(mMaxShOrder, -d, sc.shY.data());
    }
    sc.table.reset(sc.spans.front().t0);
    sc.hasPending = false;
    sc.muLast = kMuMax;
    sc.sEntry = -1.0;
    Cursor cur;
    cur.jitter = jitter;
    const double zero[3] = {0, 0, 0};
    double lastB = 0.0;

    for (int node = 0; node < kMaxNodes; ++node) {
        // A stopped render (RenderControl.h) ends the l-march here, and inside a node's passes
        // below: cancel within a second however many nodes a ray has. The film is discarded.
        if (mCtx->stop.raised())
            break;
        const TableEntry e0 = sc.table.back();
        const double sigmaMarch = std::sqrt(std::max(0.0, 0.5 * mSetup.blurK * sc.muLast * e0.P));
        const double lTarget = e0.lhat + mSetup.lStep * std::max(1.0, e0.lhat);
        double budget = kNodeSpatial * std::max(sigmaMarch, double(mMinLightVoxel));
        std::fill(sc.nodeW.begin(), sc.nodeW.end(), 0.0);
        bool done = false;
        for (int pass = 0; sc.table.back().lhat < lTarget && budget > 0.0; ++pass) {
            if (pass == kMaxPassesPerNode ||
                (pass % kStopPollInterval == kStopPollInterval - 1 && mCtx->stop.raised())) {
                done = true;
                break;
            }
            if (!sc.hasPending) {
                double maxLen = budget;
                if (lastB > 0.0)
                    maxLen = std::min(maxLen, (lTarget - sc.table.back().lhat) / lastB);
                maxLen = std::max(maxLen, 1e-3 * budget);
                if (!nextPiece(cur, sc, o, d, maxLen, sigmaMarch)) {
                    done = true;
                    break;
                }
                sc.hasPending = true;
            }
            Piece& p = sc.pending;
            if (p.gap) {
                sc.table.append(p.len, zero, zero);
                sc.hasPending = false;
                continue;
            }
            const double bhat = (p.b[0] + p.b[1] + p.b[2]) / 3.0;
            double take = std::min(p.len, budget);
            if (bhat > 0.0)
                take = std::min(take, (lTarget - sc.table.back().lhat) / bhat);
            // Round-off must not leave slivers: finish a piece that is all but consumed.
            if (p.len - take <= 1e-9 * p.len)
                take = p.len;
            if (!(take >= kMinTakeFraction * p.len))  // also NaN, from an infinite b
                take = kMinTakeFraction * p.len;
            if (sc.sEntry < 0.0 && bhat > 0.0)
                sc.sEntry = sc.table.back().s;
            sc.table.append(take, p.b, p.a);
            for (size_t v = 0; v < nv; ++v)
                sc.nodeW[v] += sc.pieceW[v] * take;
            p.len -= take;
            budget -= take;
            lastB = bhat;
            if (p.len <= 0.0)
                sc.hasPending = false;
        }
        const TableEntry& e1 = sc.table.back();
        double remaining = std::numeric_limits<double>::infinity();
        if (e1.lhat > e0.lhat) {
            evaluateNode(sc, o, d, e0, e1, sc.sums.data(), remaining);
            // Nothing the rest of the ray can add exceeds the tolerance (in units of E / 4 pi).
            if (remaining <= mSetup.tolerance)
                break;
        }
        if (done)
            break;
    }

    Rgb total = splat(0.0f);
    for (size_t si = 0; si < mSetup.sources.size(); ++si) {
        const Rgb v = make_float3(float(sc.sums[3 * si]), float(sc.sums[3 * si + 1]), float(sc.sums[3 * si + 2]));
        total += v;
        const int li = mSetup.sources[si].lightIndex;
        if (li >= 0 && perLight) {
            perLight[3 * li + 0] += v.x;
            perLight[3 * li + 1] += v.y;
            perLight[3 * li + 2] += v.z;
        }
    }
    out.L2plus += total;
}

}  // namespace nimbus::wkb
