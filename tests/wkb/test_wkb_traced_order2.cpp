// The traced second order of wkb's L2+ (src/wkb/TracedOrder2.cpp, docs/wkb.md "Order 2, traced")
// against an independent estimate of the same term: a brute-force Monte Carlo written here for a
// homogeneous box (analytic slab intersections and transmittances, no nimbus marcher, shadow map
// or phase sampler), for a distant and a point light. Both are unbiased for the box, so the
// per-ray means must agree within their combined noise plus the discretisation of nimbus's march
// (deep shadow map, step, the box's half-voxel face ramp): 3%.
#include "render/RenderContext.h"
#include "scene/KernelScene.h"
#include "wkb/TracedOrder2.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

using namespace nimbus;

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr double kHalf = 0.5;  // the box's faces at +-0.5 m
constexpr double kSigmaS = 2.0, kSigmaA = 0.25, kG = 0.5;
constexpr double kSigmaT = kSigmaS + kSigmaA;

struct V3 {
    double x, y, z;
};
V3 operator+(V3 a, V3 b) { return {a.x + b.x, a.y + b.y, a.z + b.z}; }
V3 operator-(V3 a, V3 b) { return {a.x - b.x, a.y - b.y, a.z - b.z}; }
V3 operator*(V3 a, double s) { return {a.x * s, a.y * s, a.z * s}; }
double dot(V3 a, V3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
V3 unit(V3 a) { return a * (1.0 / std::sqrt(dot(a, a))); }
V3 cross(V3 a, V3 b) { return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x}; }

// Henyey-Greenstein, normalised over the sphere.
double hg(double cosTheta)
{
    return (1.0 - kG * kG) / (4.0 * kPi * std::pow(1.0 + kG * kG - 2.0 * kG * cosTheta, 1.5));
}

// A direction about `axis` with density hg(cos): the inverse CDF of HG's cosine.
V3 sampleHg(V3 axis, double u1, double u2)
{
    const double s = (1.0 - kG * kG) / (1.0 - kG + 2.0 * kG * u1);
    const double c = std::max(-1.0, std::min(1.0, (1.0 + kG * kG - s * s) / (2.0 * kG)));
    const double sn = std::sqrt(std::max(0.0, 1.0 - c * c));
    const V3 helper = std::fabs(axis.x) < 0.9 ? V3{1, 0, 0} : V3{0, 1, 0};
    const V3 t = unit(cross(helper, axis)), b = cross(axis, t);
    const double phi = 2.0 * kPi * u2;
    return t * (sn * std::cos(phi)) + b * (sn * std::sin(phi)) + axis * c;
}

// The ray o + t d against the box: [t0, t1] clipped to t >= 0; false if it misses.
bool boxInterval(V3 o, V3 d, double& t0, double& t1)
{
    t0 = 0.0;
    t1 = 1e30;
    const double oc[3] = {o.x, o.y, o.z}, dc[3] = {d.x, d.y, d.z};
    for (int a = 0; a < 3; ++a) {
        if (std::fabs(dc[a]) < 1e-15) {
            if (std::fabs(oc[a]) > kHalf)
                return false;
            continue;
        }
        double ta = (-kHalf - oc[a]) / dc[a], tb = (kHalf - oc[a]) / dc[a];
        if (ta > tb)
            std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
    }
    return t1 > t0;
}

// Distance from a point inside the box to its boundary along d.
double exitDistance(V3 p, V3 d)
{
    double t0, t1;
    return boxInterval(p, d, t0, t1) ? t1 : 0.0;
}

struct LightCase {
    bool distant;
    V3 dir;  // distant: direction of travel
    V3 pos;  // point
    double power;
};

// Light arriving at y (inside the box) from the light, travelling along `travel`: E e^{-c dist}.
double incident(const LightCase& l, V3 y, V3& travel)
{
    if (l.distant) {
        travel = l.dir;
        return l.power * std::exp(-kSigmaT * exitDistance(y, l.dir * -1.0));
    }
    const V3 toLight = l.pos - y;
    const double r2 = dot(toLight, toLight), r = std::sqrt(r2);
    const V3 w = toLight * (1.0 / r);
    travel = w * -1.0;
    return l.power / r2 * std::exp(-kSigmaT * std::min(exitDistance(y, w), r));
}

// A point on [0, len] with density c e^{-c t} / (1 - e^{-c len}); returns t and its pdf.
double sampleExp(double len, double u, double& pdf)
{
    const double mass = -std::expm1(-kSigmaT * len);
    const double t = -std::log1p(-u * mass) / kSigmaT;
    pdf = kSigmaT * std::exp(-kSigmaT * t) / mass;
    return t;
}

// A point on [0, len] of the ray x + t w drawn equi-angularly toward c (Kulla and Fajardo 2012,
// eqs. 6-7): t = Delta + h tan(theta), theta uniform between the ends' angles; returns t and its pdf.
double sampleEquiAngular(V3 x, V3 w, V3 c, double len, double u, double& pdf)
{
    const double delta = dot(c - x, w);
    const V3 perp = (c - x) - w * delta;
    const double h = std::max(1e-9, std::sqrt(dot(perp, perp)));
    const double a = std::atan((0.0 - delta) / h), b = std::atan((len - delta) / h);
    const double t = std::min(len, std::max(0.0, delta + h * std::tan(a + u * (b - a))));
    pdf = h / ((b - a) * (h * h + (t - delta) * (t - delta)));
    return t;
}

// Order 2 reaching the camera along o + t d, by brute force: x on the camera ray by e^{-c s},
// w' by HG about d, y on x + t w' by e^{-c t} (or, `equi`, equi-angularly toward the point light:
// the light inside the box, where the inverse square makes the e^{-c t} draws' variance
// infinite), then the light at y. Per-sample standard deviation in sampleStd.
double bruteForceOrder2(const LightCase& light, V3 o, V3 d, int n, double& stdErr, bool equi = false,
                        double* sampleStd = nullptr)
{
    std::mt19937_64 gen(12345);
    std::uniform_real_distribution<double> U(0.0, 1.0);
    double t0, t1;
    if (!boxInterval(o, d, t0, t1))
        return 0.0;
    double sum = 0.0, sum2 = 0.0;
    for (int i = 0; i < n; ++i) {
        double pdfS, pdfT;
        const double s = t0 + sampleExp(t1 - t0, U(gen), pdfS);
        const V3 x = o + d * s;
        const double wS = std::exp(-kSigmaT * (s - t0)) * kSigmaS / pdfS;
        const V3 w = sampleHg(d, U(gen), U(gen));  // weight p / pdf = 1
        const double len = exitDistance(x, w);
        double v = 0.0;
        if (len > 0.0) {
            const double t = equi ? sampleEquiAngular(x, w, light.pos, len, U(gen), pdfT) : sampleExp(len, U(gen), pdfT);
            const V3 y = x + w * t;
            const double wT = std::exp(-kSigmaT * t) * kSigmaS / pdfT;
            V3 travel;
            const double E = incident(light, y, travel);
            v = wS * wT * hg(dot(travel, w * -1.0)) * E;
        }
        sum += v;
        sum2 += v * v;
    }
    const double mean = sum / n;
    stdErr = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
    if (sampleStd)
        *sampleStd = std::sqrt(std::max(0.0, sum2 / n - mean * mean));
    return mean;
}

Scene boxScene(const LightCase& lc)
{
    Scene s;
    s.camera.width = 8;
    s.camera.height = 8;
    s.render.method = Method::Wkb;
    s.render.shadowMapResolution = 512;
    s.render.wkbOrder2Samples = 1;
    Volume v;
    v.name = "box";
    v.source.type = SourceType::Procedural;
    v.source.generator = "box";
    v.source.params = {{"size", 2.0 * kHalf}, {"voxel_size", 1.0 / 32}};
    v.medium.sigma_s = splat(float(kSigmaS));
    v.medium.sigma_a = splat(float(kSigmaA));
    v.medium.phase = NbPhase{float(kG), 0, 0, 0};
    s.volumes.push_back(v);
    Light l;
    l.name = "key";
    if (lc.distant) {
        l.type = LightType::Distant;
        l.direction = make_float3(float(lc.dir.x), float(lc.dir.y), float(lc.dir.z));
        l.irradiance = splat(float(lc.power));
    } else {
        l.type = LightType::Point;
        l.position = make_float3(float(lc.pos.x), float(lc.pos.y), float(lc.pos.z));
        l.intensity = splat(float(lc.power));
    }
    s.lights.push_back(l);
    s.output.file = "unused.exr";
    return s;
}

// Each ray's traced mean against the brute force's within 3% plus four combined standard errors;
// with `inside` (a point light inside the box) the brute force draws y equi-angularly.
void checkAgainstBruteForce(const LightCase& lc, bool inside = false)
{
    const Scene scene = boxScene(lc);
    auto ctx = RenderContext::create(scene, true);
    const wkb::TracedOrder2 traced(*ctx);
    const V3 o{0.4, 0.5, 3.0};
    const V3 targets[] = {{0, 0, 0}, {0.3, 0.2, 0.1}, {-0.35, 0.3, -0.2}, {0.3, -0.4, 0.3}, {-0.2, -0.3, 0.4}};
    int ray = 0;
    for (const V3& target : targets) {
        const V3 d = unit(target - o);
        double refErr = 0.0, refStd = 0.0;
        const double ref = bruteForceOrder2(lc, o, d, 400000, refErr, inside, &refStd);
        const int n = 6000;
        double sum = 0.0, sum2 = 0.0;
        std::vector<float> perLight(3);
        for (int k = 0; k < n; ++k) {
            NbRng rng = nbRngStart(7u, nb_uint(ray * n + k), 0u);
            CameraSample cs;
            traced.add(make_float3(float(o.x), float(o.y), float(o.z)), make_float3(float(d.x), float(d.y), float(d.z)),
                       rng, cs, perLight.data());
            const double v = (cs.L2plus.x + cs.L2plus.y + cs.L2plus.z) / 3.0;
            sum += v;
            sum2 += v * v;
        }
        const double mean = sum / n;
        const double err = std::sqrt(std::max(0.0, sum2 / n - mean * mean) / n);
        const double tol = 0.03 * ref + 4.0 * std::sqrt(err * err + refErr * refErr);
        EXPECT_NEAR(mean, ref, tol) << "ray " << ray << ": traced " << mean << " +- " << err << ", brute force " << ref
                                    << " +- " << refErr;
        EXPECT_GT(ref, 0.0);
        // The light's own AOV carries the same order 2 (one light).
        EXPECT_NEAR(perLight[0] / n, sum / n, 1e-3 * std::fabs(mean) + 1e-9);
        if (inside) {
            const double std = err * std::sqrt(double(n));
            std::printf("ray %d: traced %.5f +- %.5f (sample std %.4f), brute force %.5f +- %.5f (sample std %.4f)\n",
                        ray, mean, err, std, ref, refErr, refStd);
        }
        ++ray;
    }
}

}  // namespace

TEST(WkbTracedOrder2, MatchesBruteForceUnderDistantLight)
{
    checkAgainstBruteForce(LightCase{true, unit(V3{0.3, -1.0, 0.25}), V3{0, 0, 0}, 1.0});
}

TEST(WkbTracedOrder2, MatchesBruteForceUnderPointLight)
{
    checkAgainstBruteForce(LightCase{false, V3{0, 0, 0}, V3{1.2, 1.4, 0.6}, 4.0});
}

// A point light inside the box: along the secondary directions that pass near it, the T b draws
// alone meet an inverse-square spike (infinite variance); each such direction also draws a point
// equi-angularly toward the light, combined by the balance heuristic (TracedOrder2.h). The
// combination must stay unbiased: with the equi-angular draws' weight left at 1 (counted twice)
// the traced means came out 1.6x the brute force's and this failed. Its noise: docs/wkb.md
// "Order 2, traced" (a haze box with a point light inside, beauty relMSE 0.33 -> 0.11).
TEST(WkbTracedOrder2, MatchesBruteForceWithThePointLightInsideTheMedium)
{
    checkAgainstBruteForce(LightCase{false, V3{0, 0, 0}, V3{0.1, 0.05, -0.1}, 0.5}, true);
}
