#include "BeamPathMis.h"

#include "ShadowCasters.h"

#include "../../kernels/shared/geometry.h"
#include "../../kernels/shared/light.h"

namespace nimbus::vrl {

BeamPathMis::BeamPathMis(const PathtraceScene& ps, const VrlMedium& medium, const LightPass& lights, JointKind kind,
                         NbPhase cameraPhase, int lightPaths)
    : mPs(&ps), mMedium(&medium), mLights(&lights), mKind(kind), mCameraPhase(cameraPhase), mLightPaths(lightPaths)
{
}

void BeamPathMis::setIteration(const std::vector<Vrl>& vrls)
{
    mVrls = &vrls;
    mVertices.clear();
    for (size_t i = 0; i < vrls.size(); ++i)
        if (vrls[i].order >= 1)
            mVertices.push_back(int(i));
}

bool BeamPathMis::coversLight(int light) const
{
    if (!mLights)
        return false;
    const int type = mPs->lights[size_t(light)].type;
    return type == NB_LIGHT_POINT || type == NB_LIGHT_SPOT || (type == NB_LIGHT_DISTANT && light != mPs->envLight);
}

double BeamPathMis::beamDensity(const Vrl& vrl, float t, double jointPdf) const
{
    if (!(t > 0.0f) || !(jointPdf > 0.0))
        return 0.0;
    if (vrl.order >= 1)
        return nbPhaseEval(vrl.phase, dot(vrl.inDir, vrl.dir)) * jointPdf / (double(t) * double(t));
    const double lines = double(mLightPaths) * mLights->selectionProbability(vrl.light);
    if (mPs->lights[size_t(vrl.light)].type == NB_LIGHT_DISTANT)  // dV = dA dt; the direction's pdf is the path's
        return lines * mLights->linePdf(vrl.light, vrl.origin, vrl.dir) * jointPdf;
    return lines * mLights->directionPdf(vrl.light, vrl.dir) * jointPdf / (double(t) * double(t));
}

double BeamPathMis::beamDensityTo(int light, const Vrl* vertex, float3 travel, float3 o, float3 d, float u0, float u1,
                                  float u, float3 v) const
{
    Vrl line;  // the VRL that would carry v
    if (vertex) {
        line = *vertex;
    } else {
        line.phase = mLights->lightPhase();
        line.order = 0;
        line.light = light;
    }
    float t;
    if (!vertex && mPs->lights[size_t(light)].type == NB_LIGHT_DISTANT) {
        line.dir = travel;
        line.origin = mLights->lineOrigin(v, travel);
        t = dot(v - line.origin, travel);
    } else {
        if (!vertex)
            line.origin = nbLoad3(mPs->lights[size_t(light)].position);
        const float3 toV = v - line.origin;
        t = length(toV);
        if (!(t > 0.0f))
            return 0.0;
        line.dir = toV / t;
    }
    // Its extent as the light pass gives it (VrlLightPass.cpp, tracePath).
    if (!mMedium->span(line.origin, line.dir, 0.0f, casterDistance(*mPs, line.origin, line.dir), line.t0, line.t1) ||
        t < line.t0 || t > line.t1)
        return 0.0;
    const JointSampler sampler(gatherLines(o, d, u0, u1, line), mKind, PhasePair{mCameraPhase, line.phase});
    return beamDensity(line, t, sampler.pdf(u, t));
}

double BeamPathMis::pathDensity(const MediumPoint& atU, const MediumPoint& atV, float dist, bool toLight) const
{
    const double sigmaS = nbAverage(atU.sigmaS);
    if (!(sigmaS > 0.0) || !(dist > 0.0f))
        return 0.0;
    const double count = toLight ? 1.0 : 1.0 / double(std::max<size_t>(1, mVertices.size()));
    const double phase = nbAverage(atU.scatter) / sigmaS;  // the mixture the flight's volume is drawn from
    return count * nbAverage(atU.sigmaT) * phase * nbAverage(atV.sigmaT) / (double(dist) * double(dist));
}

}  // namespace nimbus::vrl
