// Holdouts and shadow casters through single and wkb (issue 14, "How it is checked"), each
// against an independent answer: pixels held out before any medium are exactly 0 (beauty and
// alpha); the rest of the frame is bit for bit the render without the object; a sphere inside a
// homogeneous medium leaves the closed form of the medium in front of it; a plane between a
// distant light and a slab leaves L1 = 0 in its shadow and the unshadowed render beyond the
// edge, the edge where the plane projects; a light closed in by a caster lights nothing (L1 and
// L2+ = 0); a depth-map holdout made from the sphere's analytic Z equals the sphere's own
// holdout away from its silhouette.
#include "../io/TempDir.h"
#include "../render/SceneBuilders.h"

#include "engine/Renderer.h"
#include "scene/KernelScene.h"

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

using namespace nimbus;
using namespace nimbus::test;

namespace {

Geometry sphereObject(float3 centre, float radius, bool holdout, bool shadows)
{
    Geometry g;
    g.name = "ball";
    g.type = GeometryType::Sphere;
    g.radius = radius;
    g.transform = Transform::translate(centre.x, centre.y, centre.z);
    g.holdout = holdout, g.shadows = shadows;
    return g;
}

// A rectangle [x0, x1] x [z0, z1] of the plane y = height.
Geometry planeObject(float x0, float x1, float z0, float z1, float height, bool holdout, bool shadows)
{
    Geometry g;
    g.name = "board";
    g.type = GeometryType::Plane;
    g.bounded = true;
    g.size[0] = x1 - x0, g.size[1] = z1 - z0;
    g.transform = Transform::translate(0.5 * (x0 + x1), height, 0.5 * (z0 + z1));
    g.holdout = holdout, g.shadows = shadows;
    return g;
}

// The first t > 0 where o + t d meets the sphere, or INFINITY.
double sphereHit(float3 o, float3 d, float3 c, double r)
{
    const double px = o.x - c.x, py = o.y - c.y, pz = o.z - c.z;
    const double b = px * d.x + py * d.y + pz * d.z, cc = px * px + py * py + pz * pz - r * r;
    const double disc = b * b - cc;
    if (disc < 0)
        return INFINITY;
    const double t0 = -b - std::sqrt(disc), t1 = -b + std::sqrt(disc);
    return t0 > 0 ? t0 : (t1 > 0 ? t1 : INFINITY);
}

// Whether the rays through all four corners of pixel (x, y) pass `hit`, none of them, or some.
enum class Cover { All, None, Some };
Cover pixelCover(const Scene& s, int x, int y, const std::function<bool(float3, float3)>& hit)
{
    const NbCamera cam = makeNbCamera(s.camera);
    int n = 0;
    for (int c = 0; c < 4; ++c) {
        float3 o, d;
        nbCameraRay(cam, float(x + (c & 1)), float(y + (c >> 1)), s.camera.width, s.camera.height, 0.0f, &o, &d);
        n += hit(o, d);
    }
    return n == 4 ? Cover::All : (n == 0 ? Cover::None : Cover::Some);
}

const float* px(const Film& f, const char* aov, int x, int y)
{
    const Aov* a = f.find(aov);
    EXPECT_NE(a, nullptr) << aov;
    return a ? a->pixels.data() + (size_t(y) * f.width + x) * a->channels : nullptr;
}

Scene cloudScene(Method m)
{
    Scene s = emptyScene(48, 36);
    s.volumes.push_back(proceduralCloud(0.05, splat(4.0f), splat(0.1f), 0.3f));
    s.lights.push_back(distantLight("sun", make_float3(0.2f, -1, -0.3f), splat(3.0f)));
    s.camera.from = make_float3(0, 0, 6);
    s.camera.to = make_float3(0, 0, 0);
    s.camera.fov = 35;
    s.render.spp = 2;
    s.render.method = m;
    s.background = make_float3(0.2f, 0.25f, 0.3f);  // a holdout must hide it
    return s;
}

void sphereInFrontOfCloud(Method m)
{
    Scene plain = cloudScene(m);
    Scene held = plain;
    const float3 c = make_float3(0.3f, 0.1f, 2.5f);  // in front of the cloud (|z| < 1.5)
    const float r = 0.45f;
    held.geometry.push_back(sphereObject(c, r, true, false));
    const RenderResult a = render(plain), b = render(held);
    int inside = 0, outside = 0;
    for (int y = 0; y < plain.camera.height; ++y)
        for (int x = 0; x < plain.camera.width; ++x) {
            const Cover cover =
                pixelCover(plain, x, y, [&](float3 o, float3 d) { return sphereHit(o, d, c, r) < INFINITY; });
            if (cover == Cover::All) {  // every ray meets the sphere before the cloud
                ++inside;
                const float* beauty = px(b.film, "beauty", x, y);
                EXPECT_EQ(beauty[0], 0.0f) << x << "," << y;
                EXPECT_EQ(beauty[1], 0.0f);
                EXPECT_EQ(beauty[2], 0.0f);
                EXPECT_EQ(beauty[3], 0.0f);
                EXPECT_EQ(*px(b.film, "alpha", x, y), 0.0f);
                EXPECT_EQ(*px(b.film, "depth", x, y), 0.0f);
            } else if (cover == Cover::None) {  // no ray sees the sphere: the frame without it, exactly
                ++outside;
                for (const char* aov : {"beauty", "alpha", "depth", "L1"})
                    EXPECT_EQ(px(a.film, aov, x, y)[0], px(b.film, aov, x, y)[0]) << aov << " " << x << "," << y;
            }
        }
    EXPECT_GT(inside, 20);
    EXPECT_GT(outside, 1000);
}

// A homogeneous 2 m box lit from above, the camera inside it (as SingleAnalytic's Skanberg box:
// no voxelised face in front of the camera), looking at a holdout sphere inside it.
struct BoxWithSphere {
    Scene scene;
    float3 centre = make_float3(0.05f, -0.05f, -0.2f);
    float radius = 0.4f;
    Rgb sigma_s = splat(1.2f), sigma_a = splat(0.3f);
    Rgb E = splat(2.0f);
    BoxWithSphere(Method m)
    {
        scene = emptyScene(40, 40);
        scene.volumes.push_back(homogeneousBox(2, 2, 2, 1.0f / 64, sigma_s, sigma_a, 0.0f));
        scene.lights.push_back(distantLight("sun", make_float3(0, -1, 0), E));
        scene.camera.from = make_float3(0, 0, 0.9f);
        scene.camera.to = make_float3(0, 0, 0);
        scene.camera.fov = 50;
        scene.render.spp = 16;
        scene.render.method = m;
    }
};

}  // namespace

TEST(HoldoutRender, SphereInFrontOfCloudSingle)
{
    sphereInFrontOfCloud(Method::Single);
}

TEST(HoldoutRender, SphereInFrontOfCloudWkb)
{
    sphereInFrontOfCloud(Method::Wkb);
}

// L1 along a ray that meets the sphere at s_hit: the box's closed form (Skanberg eq. 43) cut at
// s_hit: int_0^s_hit sigma_s E p e^{-sigma_t s} e^{-sigma_t (d0 + k s)} ds = A (1 - e^{-a s_hit}),
// d0 + k s the depth below the top face, p = 1/(4 pi); alpha = 1 - e^{-sigma_t s_hit}.
// Tolerance: the march's last step before the holdout counts whole or not at all (stratified:
// right on average), so a sample's s_hit is off by at most one step dt, and
// dL1 <= A a e^{-a s} dt <= L1 dt / s_hit, dalpha <= sigma_t dt; beyond that only the closed
// form's own spread across the pixel (its corner and centre rays).
TEST(HoldoutRender, SphereInsideHomogeneousMediumKeepsTheMediumInFront)
{
    BoxWithSphere b(Method::Single);
    const Scene& s = b.scene;
    Scene held = s;
    held.geometry.push_back(sphereObject(b.centre, b.radius, true, false));
    const RenderResult r = render(held);
    const NbCamera cam = makeNbCamera(s.camera);
    const double sigmaT = (b.sigma_s + b.sigma_a).x, sigmaS = b.sigma_s.x, E = b.E.x;
    const double dt = s.render.step / 64.0;
    auto closedForm = [&](float3 o, float3 d, double& alpha) {
        const double sHit = sphereHit(o, d, b.centre, b.radius);
        const double d0 = 1.0 - o.y, k = -d.y;
        const double a = sigmaT * (1.0 + k);
        alpha = -std::expm1(-sigmaT * sHit);
        return sigmaS * E * NB_INV_4PI_D * std::exp(-sigmaT * d0) * -std::expm1(-a * sHit) / a;
    };
    int checked = 0;
    for (int y = 0; y < s.camera.height; ++y)
        for (int x = 0; x < s.camera.width; ++x) {
            if (pixelCover(s, x, y, [&](float3 o, float3 d) { return sphereHit(o, d, b.centre, b.radius) < INFINITY; }) !=
                Cover::All)
                continue;
            double lo = 1e30, hi = -1e30, alo = 1e30, ahi = -1e30, alpha, sMin = 1e30;
            for (int c = 0; c < 5; ++c) {
                float3 o, d;
                const float fx = c < 4 ? float(x + (c & 1)) : x + 0.5f, fy = c < 4 ? float(y + (c >> 1)) : y + 0.5f;
                nbCameraRay(cam, fx, fy, s.camera.width, s.camera.height, 0.0f, &o, &d);
                const double L = closedForm(o, d, alpha);
                lo = std::min(lo, L), hi = std::max(hi, L), alo = std::min(alo, alpha), ahi = std::max(ahi, alpha);
                sMin = std::min(sMin, sphereHit(o, d, b.centre, b.radius));
            }
            const double tolL = hi * dt / sMin, tolA = sigmaT * dt;
            const float L1 = px(r.film, "L1", x, y)[0], A = *px(r.film, "alpha", x, y);
            EXPECT_GE(L1, lo - tolL) << x << "," << y;
            EXPECT_LE(L1, hi + tolL) << x << "," << y;
            EXPECT_GE(A, alo - tolA) << x << "," << y;
            EXPECT_LE(A, ahi + tolA) << x << "," << y;
            ++checked;
        }
    EXPECT_GT(checked, 100);
}

namespace {

// A homogeneous slab 2 x 0.5 x 2 m lit straight down, seen from straight above; a board above it
// (a caster the camera does not see) over x < 0.
struct ShadowedSlab {
    Scene plain, shadowed;
    explicit ShadowedSlab(Method m)
    {
        plain = emptyScene(64, 64);
        plain.volumes.push_back(homogeneousBox(2, 0.5f, 2, 1.0f / 32, splat(2.0f), splat(0.2f), 0.0f));
        plain.lights.push_back(distantLight("sun", make_float3(0, -1, 0), splat(1.5f)));
        plain.camera.from = make_float3(0, 3, 0);
        plain.camera.to = make_float3(0, 0, 0);
        plain.camera.up = make_float3(0, 0, -1);
        plain.camera.fov = 30;
        plain.render.spp = 2;
        // Compared sample for sample below: adaptive sampling off, since its decisions read the
        // pixel's whole beauty, whose L2+ the board changes everywhere.
        plain.render.adaptiveThreshold = 0.0;
        plain.render.method = m;
        shadowed = plain;
        shadowed.geometry.push_back(planeObject(-1.5f, 0.0f, -1.5f, 1.5f, 1.0f, false, true));
    }
};

// The slab's top face is at y = 0.25; x at that depth along pixel column x's centre ray.
float slabX(const Scene& s, int x, int y)
{
    float3 o, d;
    nbCameraRay(makeNbCamera(s.camera), x + 0.5f, y + 0.5f, s.camera.width, s.camera.height, 0.0f, &o, &d);
    return o.x + d.x * (0.25f - o.y) / d.y;
}

void planeShadowsSlab(Method m)
{
    ShadowedSlab slab(m);
    const RenderResult a = render(slab.plain), b = render(slab.shadowed);
    const Scene& s = slab.plain;
    // The edge where the board's edge x = 0 projects, blurred by no more than the map's bilinear
    // lookup (one texel, 2 / 86 m: the orthographic map's resolution is capped at 0.75 voxel over
    // the 2 m footprint), the bake on the voxels read trilinearly (one voxel, 1/32 m) and the
    // pixel filter's reach (half a pixel each side): beyond that margin the pixels are either in
    // full shadow or exactly the unshadowed render. (The camera's rays shift by under 0.2 voxel
    // in x through the slab's depth.)
    const float pixel = 2.0f * 2.75f * std::tan(15.0f * float(M_PI) / 180.0f) / float(s.camera.width);
    const float margin = 1.0f / 32 + 2.0f / 86 + pixel;
    // The slab seen straight down, lit straight down: sigma_s E p (1 - e^{-2 sigma_t H}) / (2 sigma_t).
    const float litClosedForm = 2.0f * 1.5f * float(NB_INV_4PI_D) * -std::expm1(-2.0f * 2.2f * 0.5f) / (2.0f * 2.2f);
    int dark = 0, lit = 0;
    for (int y = 4; y < s.camera.height - 4; ++y)
        for (int x = 0; x < s.camera.width; ++x) {
            const float sx = slabX(s, x, y);
            if (std::fabs(sx) > 0.95f)
                continue;  // the slab's sides
            const float lit1 = px(a.film, "L1", x, y)[0], l1 = px(b.film, "L1", x, y)[0];
            if (sx < -margin) {  // under the board: no direct light (closed form: L1 = 0)
                EXPECT_LE(l1, 1e-30f) << x << "," << y;
                EXPECT_GT(lit1, 0.5f * litClosedForm);  // and lit without the board
                ++dark;
            } else if (sx > margin) {  // beyond the edge: exactly the render without the board
                EXPECT_EQ(l1, lit1) << x << "," << y;
                ++lit;
            }
        }
    EXPECT_GT(dark, 1000);
    EXPECT_GT(lit, 1000);
}

}  // namespace

TEST(ShadowRender, PlaneBetweenSunAndSlabSingle)
{
    planeShadowsSlab(Method::Single);
}

// wkb's L1 is single's; the light volumes (E from the shadow map) see the board too.
TEST(ShadowRender, PlaneBetweenSunAndSlabWkb)
{
    planeShadowsSlab(Method::Wkb);
}

// A board over the whole slab: no light reaches the medium, so every term that carries light is
// 0 everywhere (closed form), for the delta light's shadow map and wkb's light volumes alike.
TEST(ShadowRender, BoardOverTheWholeSlabDarkensL1AndL2plus)
{
    ShadowedSlab slab(Method::Wkb);
    Scene s = slab.plain;
    s.geometry.push_back(planeObject(-2, 2, -2, 2, 1.0f, false, true));
    const RenderResult r = render(s);
    const RenderResult lit = render(slab.plain);
    double litL2 = 0;
    for (int y = 0; y < s.camera.height; ++y)
        for (int x = 0; x < s.camera.width; ++x) {
            for (int c = 0; c < 3; ++c) {
                EXPECT_LE(px(r.film, "L1", x, y)[c], 1e-30f) << x << "," << y;
                // wkb's order 2 is traced through single's march (docs/wkb.md), so it carries L1's
                // own residue (a shadow map's transmittance under the board is not exactly 0).
                EXPECT_LE(px(r.film, "L2plus", x, y)[c], 1e-30f) << x << "," << y;
            }
            litL2 += px(lit.film, "L2plus", x, y)[0];
        }
    EXPECT_GT(litL2, 1.0);  // the slab without the board does scatter multiply
}

// Other light types' paths: a point light (cube shadow map) closed in a sphere, and a rect light
// (sampled with shadow rays; an SH source of wkb's light volumes) under a board: both dark.
TEST(ShadowRender, EnclosedPointLightAndCoveredRectLightLightNothing)
{
    ShadowedSlab slab(Method::Wkb);
    Scene point = slab.plain;
    point.lights.clear();
    Light p;
    p.name = "bulb";
    p.type = LightType::Point;
    p.position = make_float3(0.3f, 1.0f, 0.2f);
    p.intensity = splat(5.0f);
    point.lights.push_back(p);
    point.geometry.push_back(sphereObject(p.position, 0.1f, false, true));
    Scene rect = slab.plain;
    rect.lights.clear();
    Light l;
    l.name = "panel";
    l.type = LightType::Rect;
    l.center = make_float3(0, 1.5f, 0);
    l.normal = make_float3(0, -1, 0);
    l.size[0] = l.size[1] = 0.5f;
    l.radiance = splat(4.0f);
    rect.lights.push_back(l);
    rect.geometry.push_back(planeObject(-3, 3, -3, 3, 1.0f, false, true));
    for (const Scene* s : {&point, &rect}) {
        const RenderResult r = render(*s);
        for (int y = 0; y < s->camera.height; ++y)
            for (int x = 0; x < s->camera.width; ++x)
                for (int c = 0; c < 3; ++c) {
                    EXPECT_LE(px(r.film, "L1", x, y)[c], 1e-30f) << s->lights[0].name << " " << x << "," << y;
                    EXPECT_LE(px(r.film, "L2plus", x, y)[c], 1e-30f) << s->lights[0].name << " " << x << "," << y;
                }
    }
}

// The sphere's Z (camera-space depth of its first hit along each pixel's centre ray, written to an
// EXR with OpenImageIO) as a depth-map holdout, against the sphere itself as a holdout object.
// Away from the silhouette (pixels whose corner rays all hit or all miss it, and not next to one
// that does neither) they differ only where a sample's last step falls between the two clip
// depths: at most one march step per sample, |dalpha| <= 1 - e^{-sigma_t dt}, |dL1| <= L1 dt /
// s_hit (as in SphereInsideHomogeneousMediumKeepsTheMediumInFront).
TEST(HoldoutRender, DepthMapHoldoutEqualsTheSphereHoldout)
{
    TempDir dir;
    BoxWithSphere b(Method::Single);
    Scene geometric = b.scene;
    geometric.geometry.push_back(sphereObject(b.centre, b.radius, true, false));
    const Scene& s = b.scene;
    const int w = s.camera.width, h = s.camera.height;
    const NbCamera cam = makeNbCamera(s.camera);
    const float3 forward = normalize(s.camera.to - s.camera.from);
    std::vector<float> z(size_t(w) * h);
    std::vector<Cover> cover(size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float3 o, d;
            nbCameraRay(cam, x + 0.5f, y + 0.5f, w, h, 0.0f, &o, &d);
            const double t = sphereHit(o, d, b.centre, b.radius);
            z[size_t(y) * w + x] = t < INFINITY ? float(t * dot(d, forward)) : INFINITY;
            cover[size_t(y) * w + x] =
                pixelCover(s, x, y, [&](float3 oo, float3 dd) { return sphereHit(oo, dd, b.centre, b.radius) < INFINITY; });
        }
    const std::string path = dir / "z.exr";
    {
        OIIO::ImageSpec spec(w, h, 1, OIIO::TypeDesc::FLOAT);
        spec.channelnames = {"Z"};
        auto out = OIIO::ImageOutput::create(path);
        ASSERT_TRUE(out && out->open(path, spec));
        ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, z.data()));
        out->close();
    }
    Scene depthMapped = b.scene;
    depthMapped.camera.holdoutDepth.file = path;
    const RenderResult g = render(geometric), m = render(depthMapped);
    const double sigmaT = (b.sigma_s + b.sigma_a).x, dt = s.render.step / 64.0;
    int compared = 0;
    for (int y = 1; y + 1 < h; ++y)
        for (int x = 1; x + 1 < w; ++x) {
            bool nearSilhouette = false;
            for (int dy = -1; dy <= 1; ++dy)
                for (int dx = -1; dx <= 1; ++dx)
                    nearSilhouette |= cover[size_t(y + dy) * w + x + dx] == Cover::Some;
            if (nearSilhouette)
                continue;
            float3 o, d;
            nbCameraRay(cam, x + 0.5f, y + 0.5f, w, h, 0.0f, &o, &d);
            const double sHit = std::min(sphereHit(o, d, b.centre, b.radius), 1.0);
            const float ag = *px(g.film, "alpha", x, y), am = *px(m.film, "alpha", x, y);
            const float lg = px(g.film, "L1", x, y)[0], lm = px(m.film, "L1", x, y)[0];
            EXPECT_NEAR(am, ag, -std::expm1(-sigmaT * dt) + 1e-6) << x << "," << y;
            EXPECT_NEAR(lm, lg, lg * dt / (sHit - 2 * dt) + 1e-6) << x << "," << y;
            ++compared;
        }
    EXPECT_GT(compared, 1000);
}

// ---- the path tracer (issue 14, item 3) -----------------------------------------------------

namespace {

void usePathtraceKernelCache()
{
    setenv("NIMBUS_CACHE_DIR", (std::string(::testing::TempDir()) + "nimbus-kernel-cache-geometry").c_str(), 1);
}

// Whether every ray through the square of the pixel filter's support around pixel (x, y)'s
// centre, widened by a quarter pixel, passes `hit` (All), none does (None), or some (Some),
// sampled on a 9 x 9 grid. The path tracer's samples land anywhere in that support (filter.h),
// not only inside the pixel. A sphere's silhouette is an ellipse of radius ~8 pixels here: it
// cannot slip between grid points 0.44 pixels apart by more than their sagitta (0.003 pixels),
// well inside the quarter-pixel widening.
Cover supportCover(const Scene& s, int x, int y, const std::function<bool(float3, float3)>& hit, float extra = 0.0f)
{
    const NbCamera cam = makeNbCamera(s.camera);
    const float reach = 0.5f * s.render.filterWidth + 0.25f + extra;
    int n = 0;
    for (int j = 0; j < 9; ++j)
        for (int i = 0; i < 9; ++i) {
            float3 o, d;
            nbCameraRay(cam, x + 0.5f + reach * (i / 4.0f - 1.0f), y + 0.5f + reach * (j / 4.0f - 1.0f),
                        s.camera.width, s.camera.height, 0.0f, &o, &d);
            n += hit(o, d);
        }
    return n == 81 ? Cover::All : (n == 0 ? Cover::None : Cover::Some);
}

}  // namespace

// A holdout sphere in front of the cloud: every sample of a pixel whose filter support lies on
// the sphere ends there before any medium, so beauty (RGBA), alpha and depth are exactly 0, as in
// single and wkb. Pixels whose support misses it trace the same paths with the same random
// numbers as without the sphere (the camera's BVH query draws none): the same values, to the
// rounding a differently specialised kernel may differ by.
TEST(HoldoutRender, SphereInFrontOfCloudPathtrace)
{
    usePathtraceKernelCache();
    Scene plain = cloudScene(Method::Pathtrace);
    plain.render.spp = 16;
    Scene held = plain;
    const float3 c = make_float3(0.3f, 0.1f, 2.5f);
    const float r = 0.45f;
    held.geometry.push_back(sphereObject(c, r, true, false));
    const RenderResult a = render(plain), b = render(held);
    int inside = 0, outside = 0;
    for (int y = 0; y < plain.camera.height; ++y)
        for (int x = 0; x < plain.camera.width; ++x) {
            const Cover cover =
                supportCover(plain, x, y, [&](float3 o, float3 d) { return sphereHit(o, d, c, r) < INFINITY; });
            if (cover == Cover::All) {
                ++inside;
                const float* beauty = px(b.film, "beauty", x, y);
                for (int k = 0; k < 4; ++k)
                    EXPECT_EQ(beauty[k], 0.0f) << x << "," << y << " channel " << k;
                EXPECT_EQ(*px(b.film, "alpha", x, y), 0.0f) << x << "," << y;
                EXPECT_EQ(*px(b.film, "depth", x, y), 0.0f) << x << "," << y;
            } else if (cover == Cover::None) {
                ++outside;
                for (const char* aov : {"beauty", "alpha", "L1", "L2plus"}) {
                    const float u = px(a.film, aov, x, y)[0], v = px(b.film, aov, x, y)[0];
                    EXPECT_NEAR(u, v, 1e-5f * std::fabs(u) + 1e-7f) << aov << " " << x << "," << y;
                }
            }
        }
    EXPECT_GT(inside, 20);
    EXPECT_GT(outside, 1000);
}

// The board over x < 0 (a shadow caster the camera does not see) between the sun and the slab,
// through the path tracer with max depth 1 (so beauty = L1 and the variance AOV is L1's): in the
// board's shadow every light sample is blocked, L1 = 0 exactly (the closed form: no direct
// light); beyond the edge L1 agrees with single's per pixel within the path tracer's noise
// (mean z^2 ~ 1) and in the mean within 4 standard errors plus single's shadow-map tolerance
// (0.2%). The camera sees the slab through the board: alpha under it is the plain render's.
TEST(ShadowRender, PlaneBetweenSunAndSlabPathtrace)
{
    usePathtraceKernelCache();
    ShadowedSlab slab(Method::Pathtrace);
    slab.shadowed.render.spp = 256;
    slab.shadowed.render.maxDepth = 1;
    Scene single = slab.shadowed;
    single.render.method = Method::Single;
    single.render.spp = 64;  // its jitter noise well below the path tracer's
    const RenderResult pt = render(slab.shadowed), ref = render(single);
    const Scene& s = slab.shadowed;
    // A sample lands within the filter's radius (filterWidth / 2 pixels) of the pixel centre, and
    // the shadow's edge x = 0 is vertical (the sun straight down); the rays diverge away from it
    // on the shadowed side, so only the radius, at the slab's bottom (3.25 m away), matters.
    const float pixelAtBottom = 2.0f * 3.25f * std::tan(15.0f * float(M_PI) / 180.0f) / float(s.camera.width);
    const float margin = (0.5f * s.render.filterWidth + 0.25f) * pixelAtBottom;
    const float litClosedForm = 2.0f * 1.5f * float(NB_INV_4PI_D) * -std::expm1(-2.0f * 2.2f * 0.5f) / (2.0f * 2.2f);
    int dark = 0, lit = 0;
    double ptSum = 0, refSum = 0, varSum = 0, z2 = 0, alphaDark = 0;
    for (int y = 4; y < s.camera.height - 4; ++y)
        for (int x = 0; x < s.camera.width; ++x) {
            const float sx = slabX(s, x, y);
            if (std::fabs(sx) > 0.9f)
                continue;  // the slab's sides
            const float* l1 = px(pt.film, "L1", x, y);
            if (sx < -margin) {
                for (int k = 0; k < 3; ++k)
                    EXPECT_EQ(l1[k], 0.0f) << x << "," << y;
                float3 o, d;
                nbCameraRay(makeNbCamera(s.camera), x + 0.5f, y + 0.5f, s.camera.width, s.camera.height, 0.0f, &o, &d);
                alphaDark += *px(pt.film, "alpha", x, y) + std::expm1(-2.2 * 0.5 / std::fabs(d.y));
                ++dark;
            } else if (sx > margin + 1.0f / 32) {  // single's own edge: one voxel of the bake
                const double p = l1[0], q = px(ref.film, "L1", x, y)[0], v = *px(pt.film, "variance", x, y);
                ptSum += p, refSum += q, varSum += v;
                z2 += (p - q) * (p - q) / v;
                ++lit;
            }
        }
    ASSERT_GT(dark, 800);
    ASSERT_GT(lit, 800);
    const double ptMean = ptSum / lit, refMean = refSum / lit, se = std::sqrt(varSum) / lit;
    std::printf("lit L1: path tracer %.5f +- %.5f, single %.5f, closed form (infinite slab) %.5f; mean z^2 %.2f over "
                "%d pixels; %d dark pixels, their alpha minus the closed form %+.5f\n",
                ptMean, se, refMean, litClosedForm, z2 / lit, lit, dark, alphaDark / dark);
    EXPECT_LT(std::fabs(ptMean - refMean), 4 * se + 0.002 * refMean);
    EXPECT_LT(z2 / lit, 1.5);
    // Alpha against 1 - e^{-sigma_t H / |d_y|} along each pixel's centre ray (H 0.5 m, sigma_t
    // 2.2/m): the board does not hide the slab from the camera. At max depth 1 a sample's alpha is
    // 0 or 1 (escaped or scattered), variance T (1 - T) = 0.22, so the mean over ~1700 pixels of
    // 256 samples has a standard error of 7e-4: 0.003 is about 4 of them (the filter's spread of
    // directions within a pixel moves the closed form by < 1e-4).
    EXPECT_NEAR(alphaDark / dark, 0.0, 0.003);
}

// Flags choose the rays: a board outside the camera's view, between a slanted sun and the slab.
// As a holdout only it changes nothing (holdouts affect camera visibility only: light samples
// and path segments pass it), so L1 and L2plus equal the render without it; as a shadow caster
// it darkens the slab (L1 where the board's shadow falls is 0).
TEST(ShadowRender, HoldoutOnlyBoardDoesNotBlockLightPathtrace)
{
    usePathtraceKernelCache();
    ShadowedSlab slab(Method::Pathtrace);
    Scene plain = slab.plain;
    plain.lights[0] = distantLight("sun", make_float3(1, -1, 0), splat(1.5f));
    plain.render.spp = 8;
    Scene holdoutOnly = plain, caster = plain;
    // y = 1, x in [-3, -0.6]: outside the view (|x| < 0.54 at y = 1); its shadow on the slab's
    // top (y = 0.25) under light travelling along +x, -y reaches x < 0.15.
    holdoutOnly.geometry.push_back(planeObject(-3.0f, -0.6f, -3.0f, 3.0f, 1.0f, true, false));
    caster.geometry.push_back(planeObject(-3.0f, -0.6f, -3.0f, 3.0f, 1.0f, false, true));
    const RenderResult a = render(plain), b = render(holdoutOnly), c = render(caster);
    double plainL1 = 0, casterL1 = 0;
    int compared = 0;
    for (int y = 0; y < plain.camera.height; ++y)
        for (int x = 0; x < plain.camera.width; ++x) {
            for (const char* aov : {"L1", "L2plus", "alpha"}) {
                const float u = px(a.film, aov, x, y)[0], v = px(b.film, aov, x, y)[0];
                EXPECT_NEAR(u, v, 1e-5f * std::fabs(u) + 1e-7f) << aov << " " << x << "," << y;
            }
            ++compared;
            if (slabX(plain, x, y) < -0.3f && std::fabs(slabX(plain, x, y)) < 0.9f) {
                plainL1 += px(a.film, "L1", x, y)[0];
                casterL1 += px(c.film, "L1", x, y)[0];
                EXPECT_EQ(px(c.film, "L1", x, y)[0], 0.0f) << x << "," << y;
            }
        }
    EXPECT_EQ(compared, plain.camera.width * plain.camera.height);
    EXPECT_GT(plainL1, 10.0);
    EXPECT_EQ(casterL1, 0.0);
}

// A depth-map holdout through the path tracer: the sphere of SphereInFrontOfCloudPathtrace as its
// camera-space Z (analytic, per pixel centre, written to an EXR) instead of as an object. Every
// depth the lookup returns on the sphere lies in front of the cloud, so pixels whose filter
// support lies on the sphere are exactly 0 (beauty, alpha), and pixels whose support stays more
// than 1.5 pixels off its silhouette (the lookup reads the four nearest pixel centres) are the
// render without it.
TEST(HoldoutRender, DepthMapHoldoutPathtrace)
{
    usePathtraceKernelCache();
    TempDir dir;
    Scene plain = cloudScene(Method::Pathtrace);
    plain.render.spp = 8;
    const float3 c = make_float3(0.3f, 0.1f, 2.5f);
    const float r = 0.45f;
    const int w = plain.camera.width, h = plain.camera.height;
    const NbCamera cam = makeNbCamera(plain.camera);
    const float3 forward = normalize(plain.camera.to - plain.camera.from);
    std::vector<float> z(size_t(w) * h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float3 o, d;
            nbCameraRay(cam, x + 0.5f, y + 0.5f, w, h, 0.0f, &o, &d);
            const double t = sphereHit(o, d, c, r);
            z[size_t(y) * w + x] = t < INFINITY ? float(t * dot(d, forward)) : 0.0f;  // 0: no holdout
        }
    const std::string path = dir / "z.exr";
    {
        OIIO::ImageSpec spec(w, h, 1, OIIO::TypeDesc::FLOAT);
        spec.channelnames = {"Z"};
        auto out = OIIO::ImageOutput::create(path);
        ASSERT_TRUE(out && out->open(path, spec));
        ASSERT_TRUE(out->write_image(OIIO::TypeDesc::FLOAT, z.data()));
        out->close();
    }
    Scene held = plain;
    held.camera.holdoutDepth.file = path;
    const RenderResult a = render(plain), b = render(held);
    auto onSphere = [&](float3 o, float3 d) { return sphereHit(o, d, c, r) < INFINITY; };
    int inside = 0, outside = 0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            if (supportCover(plain, x, y, onSphere) == Cover::All) {
                ++inside;
                for (int k = 0; k < 4; ++k)
                    EXPECT_EQ(px(b.film, "beauty", x, y)[k], 0.0f) << x << "," << y;
                EXPECT_EQ(*px(b.film, "alpha", x, y), 0.0f) << x << "," << y;
            } else if (supportCover(plain, x, y, onSphere, 1.5f) == Cover::None) {
                ++outside;
                for (const char* aov : {"beauty", "alpha", "L1", "L2plus"}) {
                    const float u = px(a.film, aov, x, y)[0], v = px(b.film, aov, x, y)[0];
                    EXPECT_NEAR(u, v, 1e-5f * std::fabs(u) + 1e-7f) << aov << " " << x << "," << y;
                }
            }
        }
    EXPECT_GT(inside, 20);
    EXPECT_GT(outside, 1000);
}
