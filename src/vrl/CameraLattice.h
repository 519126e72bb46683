// CameraLattice.h: camera rays through a regular lattice of pixel centres at the shutter's
// centre, the probes with which the orders-3+ cache looks at the image before it is filled: the
// skin cells' camera pass (SkinCells.h), the view's focus (ViewFocus.h) and the adaptive count's
// pilot rays (Orders3Grid.cpp).
#pragma once

#include "../scene/KernelScene.h"

#include <algorithm>
#include <cmath>

namespace nimbus::vrl {

struct CameraLattice {
    static constexpr float kShutter = 0.5f;

    // `rays` lattice points along the image's longer side (the shorter in proportion, at least 1).
    CameraLattice(const Camera& cam, int rays)
        : nc(makeNbCamera(cam)), W(std::max(1, cam.width)), H(std::max(1, cam.height))
    {
        const double scale = double(rays) / double(std::max(W, H));
        nx = std::max(1, int(std::lround(double(W) * scale)));
        ny = std::max(1, int(std::lround(double(H) * scale)));
    }

    // The ray through lattice point (px, py), px < nx, py < ny: origin and unit direction.
    void ray(int px, int py, float3& o, float3& d) const
    {
        nbCameraRay(nc, (float(px) + 0.5f) * float(W) / float(nx), (float(py) + 0.5f) * float(H) / float(ny), W, H,
                    kShutter, &o, &d);
    }
    // The ray through image point (x, y) in pixels.
    void rayAt(float x, float y, float3& o, float3& d) const { nbCameraRay(nc, x, y, W, H, kShutter, &o, &d); }
    // The camera's eye: the origin of the ray through the image's centre.
    float3 eye() const
    {
        float3 o, d;
        rayAt(0.5f * float(W), 0.5f * float(H), o, d);
        return o;
    }

    NbCamera nc;
    int W, H;
    int nx = 1, ny = 1;
};

}  // namespace nimbus::vrl
