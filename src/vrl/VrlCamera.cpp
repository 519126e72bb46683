#include "VrlCamera.h"

#include "ShadowCasters.h"

#include "../../kernels/shared/envmap.h"
#include "../../kernels/shared/geometry.h"
#include "../../kernels/shared/light.h"

#include <cmath>

namespace nimbus::vrl {

namespace {

constexpr int kRussianRouletteDepth = 3;  // the path tracer's
constexpr int kSafetyMaxDepth = 1000000;

// Next-event estimation at p for every light, light arriving along -wi and leaving along -d
// (pathtrace.cl's loop, one sample each).
void nextEvent(const CameraSetup& s, float3 p, float3 d, NbPhase phase, float3 w, NbRng& rng, CameraSample& out)
{
    const PathtraceScene& ps = *s.ps;
    const VrlMedium& m = *s.medium;
    for (size_t i = 0; i < ps.lights.size(); ++i) {
        const NbLight& l = ps.lights[i];
        const float u0 = nbRngNext(&rng), u1 = nbRngNext(&rng);
        if (int(i) == ps.envLight) {
            const float3 colour = nbLoad3(l.color);
            float3 c = make_float3(0, 0, 0);
            float pdfMap;
            float3 wi = nbEnvSample(ps.envMap, ps.envData.data(), u0, u1, &pdfMap);
            float fp = nbPhaseEval(phase, dot(wi, d));
            if (pdfMap > 0.0f && fp > 0.0f) {
                const float3 L = colour * nbEnvLookup(ps.envMap, ps.envData.data(), wi);
                if (nbMaxComponent(L) > 0.0f && !casterBetween(ps, p, wi, NB_INF)) {
                    const float mis = pdfMap * pdfMap / (pdfMap * pdfMap + fp * fp);
                    c += L * m.transmittance(p, wi, NB_INF, rng) * (fp * mis / pdfMap);
                }
            }
            const float v0 = nbRngNext(&rng), v1 = nbRngNext(&rng), v2 = nbRngNext(&rng);
            wi = nbPhaseSample(phase, d, v0, v1, v2);
            fp = nbPhaseEval(phase, dot(wi, d));
            const float3 L = colour * nbEnvLookup(ps.envMap, ps.envData.data(), wi);
            if (fp > 0.0f && nbMaxComponent(L) > 0.0f && !casterBetween(ps, p, wi, NB_INF)) {
                pdfMap = nbEnvPdf(ps.envMap, ps.envData.data(), wi);
                const float mis = fp * fp / (pdfMap * pdfMap + fp * fp);
                c += L * m.transmittance(p, wi, NB_INF, rng) * mis;
            }
            c = w * c;
            out.L[1] += c;
            out.perLight[i] += c;
            continue;
        }
        NbLightSample ls;
        float f;
        if (l.type == NB_LIGHT_ENVIRONMENT) {
            ls.wi = nbPhaseSample(phase, d, u0, u1, nbRngNext(&rng));
            ls.distance = NB_INF;
            ls.weight = nbLoad3(l.color);
            f = 1.0f;
        } else {
            ls = nbLightSample(l, p, u0, u1);
            f = nbPhaseEval(phase, dot(ls.wi, d));
        }
        if (!(nbMaxComponent(ls.weight) > 0.0f) || !(f > 0.0f))
            continue;
        if (casterBetween(ps, p, ls.wi, ls.distance))
            continue;
        const float3 c = w * ls.weight * m.transmittance(p, ls.wi, ls.distance, rng) * f;
        out.L[1] += c;
        out.perLight[i] += c;
    }
}

}  // namespace

float3 gatherVrl(const CameraSetup& s, const Vrl& vrl, float3 o, float3 d, float u0, float u1, NbRng& rng)
{
    const float xi0 = nbRngNext(&rng), xi1 = nbRngNext(&rng);
    const JointSampler sampler(gatherLines(o, d, u0, u1, vrl), s.kind, PhasePair{s.cameraPhase, vrl.phase});
    const PairSample ps = sampler.sample(xi0, xi1);
    if (!(ps.pdf > 0.0) || !std::isfinite(ps.pdf))
        return make_float3(0, 0, 0);
    const float3 pu = o + d * float(ps.u), pv = vrl.origin + vrl.dir * float(ps.v);
    const float3 between = pu - pv;
    const float dist2 = dot(between, between);
    if (!(dist2 > 0.0f))
        return make_float3(0, 0, 0);
    const float dist = std::sqrt(dist2);
    const float3 w = between / dist;  // light travels v -> u
    const VrlMedium& m = *s.medium;
    const MediumPoint atV = m.at(pv, dot(vrl.dir, w));
    if (!(nbMaxComponent(atV.scatter) > 0.0f))
        return make_float3(0, 0, 0);
    const MediumPoint atU = m.at(pu, -dot(w, d));
    if (!(nbMaxComponent(atU.scatter) > 0.0f))
        return make_float3(0, 0, 0);
    if (casterBetween(*s.ps, pv, w, dist))
        return make_float3(0, 0, 0);
    float3 c = vrl.flux * atV.scatter * atU.scatter * float(1.0 / (double(dist2) * ps.pdf));
    if (s.mis.active() && (vrl.order >= 1 || s.mis.coversLight(vrl.light)))  // BeamPathMis.h
        c = c * balanceWeight(s.mis.beamDensity(vrl, float(ps.v), ps.pdf),
                              s.mis.pathDensity(atU, atV, dist, vrl.order == 0));
    // The transmittances last, each only while the product can still be non-zero.
    c = c * m.transmittance(pv, w, dist, rng);
    if (!(nbMaxComponent(c) > 0.0f))
        return c;
    c = c * m.transmittance(o, d, float(ps.u), rng);
    if (!(nbMaxComponent(c) > 0.0f))
        return c;
    return c * m.transmittance(vrl.origin, vrl.dir, float(ps.v), rng);
}

namespace {

// The path technique of BeamPathMis.h from the camera path's first scattering vertex p = o + u d
// (throughput w, phase function `phase` there): a phase-sampled direction, a free flight to v,
// next-event estimation at v for each point, spot and distant light, and a connection to one light vertex
// (the origin of a VRL of order >= 1, chosen uniformly), each weighted against the beam
// technique. [u0, u1]: the camera segment the gathers sample.
void pathTechnique(const CameraSetup& s, float3 o, float3 d, float u0, float u1, float u, NbPhase phase, float3 w,
                   NbRng& rng, CameraSample& out)
{
    const PathtraceScene& ps = *s.ps;
    const VrlMedium& m = *s.medium;
    const float3 p = o + d * u;
    const float x0 = nbRngNext(&rng), x1 = nbRngNext(&rng), x2 = nbRngNext(&rng);
    const float3 wo = nbPhaseSample(phase, d, x0, x1, x2);
    const FlightResult f = m.freeFlight(p, wo, casterDistance(ps, p, wo), w, rng, nullptr);
    if (!f.scattered)
        return;
    const float3 v = p + wo * f.t;
    const NbPhase phaseV = m.phase(f.volume);
    const MediumPoint atU = m.at(p, dot(d, wo)), atV = m.at(v, 1.0f);
    // Next-event estimation to the point, spot and distant lights.
    for (size_t i = 0; i < ps.lights.size(); ++i) {
        if (!s.mis.coversLight(int(i)))
            continue;
        const NbLight& l = ps.lights[i];
        const bool distant = l.type == NB_LIGHT_DISTANT;  // a direction in its cone; point and spot: none
        const float a = distant ? nbRngNext(&rng) : 0.5f, b = distant ? nbRngNext(&rng) : 0.5f;
        const NbLightSample ls = nbLightSample(l, v, a, b);
        const float fv = nbPhaseEval(phaseV, dot(ls.wi, wo));
        if (!(nbMaxComponent(ls.weight) > 0.0f) || !(fv > 0.0f) || casterBetween(ps, v, ls.wi, ls.distance))
            continue;
        const float weight = balanceWeight(s.mis.pathDensity(atU, atV, f.t, true),
                                           s.mis.beamDensityTo(int(i), nullptr, -ls.wi, o, d, u0, u1, u, v));
        if (!(weight > 0.0f))
            continue;
        const float3 c = w * ls.weight * m.transmittance(v, ls.wi, ls.distance, rng) * (fv * weight);
        out.L[2] += c;
        out.perLight[i] += c;
    }
    // A connection to one light vertex x, as a virtual point light: the light path's flux there
    // times its phase function towards v, over t^2, times K for the choice.
    const int vertices = s.mis.lightVertexCount();
    if (vertices == 0)
        return;
    const Vrl& x = s.mis.lightVertex(std::min(vertices - 1, int(nbRngNext(&rng) * float(vertices))));
    const float3 toX = x.origin - v;
    const float t2 = dot(toX, toX);
    if (!(t2 > 0.0f))
        return;
    const float t = std::sqrt(t2);
    const float3 wi = toX / t;
    const float fv = nbPhaseEval(phaseV, dot(wi, wo));
    const float fx = nbPhaseEval(x.phase, dot(x.inDir, -wi));
    if (!(fv > 0.0f) || !(fx > 0.0f) || casterBetween(ps, v, wi, t))
        return;
    const float weight = balanceWeight(s.mis.pathDensity(atU, atV, f.t, false),
                                       s.mis.beamDensityTo(-1, &x, make_float3(0, 0, 0), o, d, u0, u1, u, v));
    if (!(weight > 0.0f))
        return;
    const float3 c = w * x.flux * m.transmittance(v, wi, t, rng) * (fv * fx / t2 * float(vertices) * weight);
    out.L[2] += c;
    out.perLight[size_t(x.light)] += c;
}

}  // namespace

void traceCameraPath(const CameraSetup& s, float3 o, float3 d, float tCamera, NbRng& rng, CameraSample& out)
{
    const PathtraceScene& ps = *s.ps;
    const VrlMedium& m = *s.medium;
    for (float3& L : out.L)
        L = make_float3(0, 0, 0);
    out.transmittance = out.depth = out.hasDepth = 0;
    out.scatterVolume = -1;
    out.perLight.assign(ps.lights.size(), make_float3(0, 0, 0));
    const int maxDepth = s.maxDepth > 0 ? s.maxDepth : kSafetyMaxDepth;

    // L0, L1 and emission: the path tracer's camera path.
    {
        float3 po = o, pd = d, w = make_float3(1, 1, 1);
        for (int order = 0;;) {
            const float tEnd = order == 0 ? tCamera : casterDistance(ps, po, pd);
            float3 emitted = make_float3(0, 0, 0);
            const FlightResult f = m.freeFlight(po, pd, tEnd, w, rng, ps.emission ? &emitted : nullptr);
            out.L[order < 2 ? order : 2] += emitted;
            if (!f.scattered) {
                if (order == 0) {
                    float3 bg = s.background;
                    if (ps.envLight >= 0)
                        bg += nbLoad3(ps.lights[size_t(ps.envLight)].color) *
                              nbEnvLookup(ps.envMap, ps.envData.data(), d);
                    if (!(tEnd < NB_INF))
                        out.L[0] += w * bg;
                    out.transmittance = nbAverage(w);
                }
                break;
            }
            if (order >= maxDepth)
                break;
            ++order;
            const float3 p = po + pd * f.t;
            if (order == 1) {
                out.depth = f.t;
                out.hasDepth = 1.0f;
            }
            const NbPhase phase = m.phase(f.volume);
            if (order == 1) {
                nextEvent(s, p, pd, phase, w, rng, out);
                out.scatterWeight = w;
                out.scatterVolume = f.volume;
            }
            if (!ps.emission)
                break;  // nothing more to gather: a further flight could only meet emission
            if (order >= kRussianRouletteDepth) {
                const float q = std::fmin(1.0f, nbMaxComponent(w));
                if (nbRngNext(&rng) >= q)
                    break;
                w = w / q;
            }
            const float u0 = nbRngNext(&rng), u1 = nbRngNext(&rng), u2 = nbRngNext(&rng);
            pd = nbPhaseSample(phase, pd, u0, u1, u2);
            po = p;
        }
    }
}

void gatherVrls(const CameraSetup& s, float3 o, float3 d, float tCamera, const std::vector<Vrl>& vrls, NbRng& rng,
                CameraSample& out)
{
    const VrlMedium& m = *s.medium;
    // The camera segment inside the volumes, up to a holdout.
    if (vrls.empty() || (s.maxDepth > 0 && s.maxDepth < 2))
        return;
    float u0, u1;
    if (!m.span(o, d, 0.0f, tCamera, u0, u1))
        return;
    for (const Vrl& vrl : vrls) {
        const float3 c = gatherVrl(s, vrl, o, d, u0, u1, rng);
        out.L[2] += c;
        out.perLight[size_t(vrl.light)] += c;
    }
}

void gatherPaths(const CameraSetup& s, float3 o, float3 d, float tCamera, const CameraSample& path, NbRng& rng,
                 CameraSample& out)
{
    if (!s.mis.active() || path.scatterVolume < 0 || (s.maxDepth > 0 && s.maxDepth < 2))
        return;
    float u0, u1;
    if (s.medium->span(o, d, 0.0f, tCamera, u0, u1))
        pathTechnique(s, o, d, u0, u1, path.depth, s.medium->phase(path.scatterVolume), path.scatterWeight, rng, out);
}

}  // namespace nimbus::vrl
