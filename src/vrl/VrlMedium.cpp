#include "VrlMedium.h"

#include <algorithm>
#include <cmath>

namespace nimbus::vrl {

namespace {

thread_local long long* tWork = nullptr;

inline void countWork()
{
    if (tWork)
        ++*tWork;
}

float advance(float t, float dt)
{
    const float tn = t + dt;
    return tn > t ? tn : std::nextafter(t, INFINITY);
}

float weighted(float3 w, float3 v)
{
    return nbAverage(w * v);
}

}  // namespace

VrlMedium::VrlMedium(const PathtraceScene& ps, bool residual)
    : mPs(&ps), mCount(int(ps.volumes.size())), mSlotMin(ps.volumes.size())
{
    if (!residual || ps.pnanovdb)
        return;
    for (size_t v = 0; v < ps.volumes.size(); ++v) {
        const NbVolumeDesc& vd = ps.volumes[v];
        const NbGridDesc& g = vd.density;
        if (g.dims[3] <= 0 || vd.velocity.dims[3] > 0)
            continue;
        const size_t slots = size_t(g.dims[0]) * size_t(g.dims[1]) * size_t(g.dims[2]);
        const size_t channels = size_t(g.dims[3]);
        std::vector<float>& out = mSlotMin[v];
        out.assign(slots, 0.0f);
        for (size_t slot = 0; slot < slots; ++slot) {
            const int brick = ps.tables[g.tableOffset + slot];
            if (brick < 0)
                continue;  // an empty slot reads 0
            const float* q = ps.pools.data() + g.poolOffset + size_t(brick) * NB_BRICK_VALUES * channels;
            float least = q[0];
            for (size_t i = 1; i < NB_BRICK_VALUES; ++i)
                least = std::min(least, q[i * channels]);
            out[slot] = std::max(0.0f, least);  // densities are read as max(0, value)
        }
    }
}

float3 VrlMedium::control(const NbMajorantIter& it) const
{
    float3 c = make_float3(0, 0, 0);
    for (int v = 0; v < mCount; ++v) {
        if (it.state[v] != 1 || mSlotMin[size_t(v)].empty())
            continue;
        const NbVolumeDesc& vd = mPs->volumes[size_t(v)];
        const int slot = nbGridSlot(vd.density, it.dda[v].cell[0], it.dda[v].cell[1], it.dda[v].cell[2]);
        if (slot >= 0)
            c += nbLoad3(vd.sigma_t) * mSlotMin[size_t(v)][size_t(slot)];
    }
    return c;
}

FlightResult VrlMedium::freeFlight(float3 o, float3 d, float tEnd, float3& w, NbRng& rng, float3* emission) const
{
    const PathtraceScene& ps = *mPs;
    const NbVolumeDesc* vols = ps.volumes.data();
    FlightResult r;
    NbMajorantIter it;
    nbMajorantInit(&it, vols, mCount, o, d, 0.0f, tEnd, mSeconds, ps.majorants.data());
    float tau = -std::log(rngOpen(rng));
    float segEnd, mu;
    float rho[NB_NUM_VOLUMES];
    while (nbMajorantNext(&it, vols, ps.majorants.data(), &segEnd, &mu)) {
        countWork();
        const float span = mu * (segEnd - it.t);
        if (tau >= span) {
            tau -= span;
            it.t = segEnd;
            continue;
        }
        it.t = advance(it.t, tau / mu);
        nbMajorantDensities(&it, vols, ps.tables.data(), ps.pools.data(), rho);
        countWork();
        if (emission && ps.emission)
            *emission += w * nbMajorantEmission(&it, vols, ps.tables.data(), ps.pools.data()) / mu;
        float3 sigma_t = make_float3(0, 0, 0), sigma_s = sigma_t;
        for (int v = 0; v < mCount; ++v) {
            sigma_t += nbLoad3(vols[v].sigma_t) * rho[v];
            sigma_s += nbLoad3(vols[v].sigma_s) * rho[v];
        }
        const float3 sigma_n = fmax(make_float3(0, 0, 0), make_float3(mu, mu, mu) - sigma_t);
        const float pS = weighted(w, sigma_s), pN = weighted(w, sigma_n), total = pS + pN;
        if (!(total > 0.0f)) {  // only absorption is left: the path ends
            w = make_float3(0, 0, 0);
            return r;
        }
        const float u = nbRngNext(&rng) * total;
        if (u < pS) {
            // The scattering volume in proportion to its share of avg(w sigma_s).
            int chosen = 0;
            float3 sigma_sv = nbLoad3(vols[0].sigma_s) * rho[0];
            float acc = 0;
            for (int v = 0; v < mCount; ++v) {
                const float3 s = nbLoad3(vols[v].sigma_s) * rho[v];
                const float sv = weighted(w, s);
                if (sv > 0.0f) {
                    chosen = v;
                    sigma_sv = s;
                }
                acc += sv;
                if (u < acc)
                    break;
            }
            const float pv = weighted(w, sigma_sv) / total;
            w = w * sigma_sv / (mu * pv);
            r.scattered = true;
            r.t = it.t;
            r.volume = chosen;
            return r;
        }
        w = w * sigma_n / (mu * (pN / total));
        tau = -std::log(rngOpen(rng));
    }
    return r;
}

float3 VrlMedium::transmittance(float3 o, float3 d, float tMax, NbRng& rng) const
{
    const PathtraceScene& ps = *mPs;
    const NbVolumeDesc* vols = ps.volumes.data();
    // T: the product of the residual factors (and the roulette's weights); tauC: the control's
    // optical depth so far. The estimate is T e^-tauC.
    float3 T = make_float3(1, 1, 1), tauC = make_float3(0, 0, 0);
    NbMajorantIter it;
    nbMajorantInit(&it, vols, mCount, o, d, 0.0f, tMax, mSeconds, ps.majorants.data());
    float tau = -std::log(rngOpen(rng));
    float segEnd, mu;
    float rho[NB_NUM_VOLUMES];
    // Russian roulette where the estimate's largest channel falls below 0.1: survive with
    // probability 10 m, then divide by it. A bound without the RGB exponential (the least
    // channel's control depth) skips the exact value where the estimate is clearly above 0.1.
    auto survives = [&]() {
        if (nbMaxComponent(T) * std::exp(-nbMinComponent(tauC)) < 0.1f) {
            const float m = nbMaxComponent(T * exp(-tauC));
            if (m < 0.1f) {
                if (nbRngNext(&rng) >= m * 10.0f)
                    return false;
                T = T / (m * 10.0f);
            }
        }
        return true;
    };
    while (nbMajorantNext(&it, vols, ps.majorants.data(), &segEnd, &mu)) {
        countWork();
        // Residual ratio tracking over this stretch (see the header): the control's depth in
        // closed form, tentative collisions at the residual rate muR.
        const float3 sigmaC = control(it);
        const float muR = std::max(0.0f, mu - nbMinComponent(sigmaC));
        for (;;) {
            const float span = muR * (segEnd - it.t);
            if (!(tau < span)) {
                tauC += sigmaC * (segEnd - it.t);
                tau -= span;
                it.t = segEnd;
                break;
            }
            const float dt = tau / muR;
            tauC += sigmaC * dt;
            it.t = advance(it.t, dt);
            nbMajorantDensities(&it, vols, ps.tables.data(), ps.pools.data(), rho);
            countWork();
            float3 sigma_t = make_float3(0, 0, 0);
            for (int v = 0; v < mCount; ++v)
                sigma_t += nbLoad3(vols[v].sigma_t) * rho[v];
            T = T * fmax(make_float3(0, 0, 0), make_float3(1, 1, 1) - (sigma_t - sigmaC) / muR);
            if (!survives())
                return make_float3(0, 0, 0);
            tau = -std::log(rngOpen(rng));
        }
        if (!survives())
            return make_float3(0, 0, 0);
    }
    return T * exp(-tauC);
}

MediumPoint VrlMedium::at(float3 p, float cosTheta) const
{
    countWork();
    MediumPoint out;
    out.sigmaT = out.sigmaS = out.scatter = make_float3(0, 0, 0);
    for (int v = 0; v < mCount; ++v) {
        const NbVolumeDesc& vd = mPs->volumes[size_t(v)];
        float m[12];  // at the iteration's shutter time where the transform moves (motion.h)
        nbVolumeIndexFromWorld(&vd, mPs->majorants.data(), mSeconds, m);
        float3 q = make_float3(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3], m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7],
                               m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]);
        // The majorant walk reads densities only inside the active box (state 1): the same here.
        if (!(q.x >= vd.boundsLo[0] && q.x <= vd.boundsHi[0] && q.y >= vd.boundsLo[1] && q.y <= vd.boundsHi[1] &&
              q.z >= vd.boundsLo[2] && q.z <= vd.boundsHi[2]))
            continue;
        // Velocity blur: the density read back along the velocity, as nbMajorantLookup.
        if (vd.velocity.dims[3] > 0)
            q = q - nbGridSample3(vd.velocity, mPs->tables.data(), mPs->pools.data(), q) * mSeconds;
        const float rho = nbFmax(0.0f, nbGridSample(vd.density, mPs->tables.data(), mPs->pools.data(), q));
        if (rho > 0.0f) {
            const float3 sigmaS = nbLoad3(vd.sigma_s) * rho;
            out.sigmaT += nbLoad3(vd.sigma_t) * rho;
            out.sigmaS += sigmaS;
            out.scatter += sigmaS * nbPhaseEval(vd.phase, cosTheta);
        }
    }
    return out;
}

bool VrlMedium::span(float3 o, float3 d, float tMin, float tMax, float& t0, float& t1) const
{
    NbMajorantIter it;
    nbMajorantInit(&it, mPs->volumes.data(), mCount, o, d, tMin, tMax, mSeconds, mPs->majorants.data());
    t0 = INFINITY;
    t1 = -INFINITY;
    for (int v = 0; v < mCount; ++v)
        if (it.state[v] == 0) {
            t0 = nbFmin(t0, it.tEvent[v]);
            t1 = nbFmax(t1, it.tEnd[v]);
        }
    return t1 > t0;
}

NbPhase VrlMedium::dominantPhase() const
{
    int best = 0;
    float bestS = -1;
    for (int v = 0; v < mCount; ++v) {
        const NbVolumeDesc& vd = mPs->volumes[size_t(v)];
        const float s = nbAverage(nbLoad3(vd.sigma_s)) * vd.density.maxValue;
        if (s > bestS) {
            bestS = s;
            best = v;
        }
    }
    return mCount > 0 ? mPs->volumes[size_t(best)].phase : NbPhase{0, 0, 0, 0};
}

void setWorkCounter(long long* counter)
{
    tWork = counter;
}

}  // namespace nimbus::vrl
