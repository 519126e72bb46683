#include "Transform.h"

#include "Error.h"

#include <cmath>

namespace nimbus {

Transform::Transform() : mM{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1} {}

Transform Transform::fromRowMajor(const std::array<double, 16>& m)
{
    Transform t;
    t.mM = m;
    return t;
}

Transform Transform::translate(double x, double y, double z)
{
    return fromRowMajor({1, 0, 0, x, 0, 1, 0, y, 0, 0, 1, z, 0, 0, 0, 1});
}

Transform Transform::scale(double x, double y, double z)
{
    return fromRowMajor({x, 0, 0, 0, 0, y, 0, 0, 0, 0, z, 0, 0, 0, 0, 1});
}

Transform Transform::rotateDegrees(double angle, double ax, double ay, double az)
{
    double len = std::sqrt(ax * ax + ay * ay + az * az);
    if (len == 0.0)
        return Transform();
    ax /= len, ay /= len, az /= len;
    double r = angle * M_PI / 180.0, c = std::cos(r), s = std::sin(r), t = 1.0 - c;
    // Rodrigues' rotation formula.
    return fromRowMajor({t * ax * ax + c, t * ax * ay - s * az, t * ax * az + s * ay, 0, t * ax * ay + s * az,
                         t * ay * ay + c, t * ay * az - s * ax, 0, t * ax * az - s * ay, t * ay * az + s * ax,
                         t * az * az + c, 0, 0, 0, 0, 1});
}

Transform Transform::operator*(const Transform& rhs) const
{
    Transform out;
    for (int i = 0; i < 4; ++i)
        for (int j = 0; j < 4; ++j) {
            double sum = 0;
            for (int k = 0; k < 4; ++k)
                sum += mM[i * 4 + k] * rhs.mM[k * 4 + j];
            out.mM[i * 4 + j] = sum;
        }
    return out;
}

static double det3(const std::array<double, 16>& m)
{
    return m[0] * (m[5] * m[10] - m[6] * m[9]) - m[1] * (m[4] * m[10] - m[6] * m[8]) +
           m[2] * (m[4] * m[9] - m[5] * m[8]);
}

bool Transform::isSingular() const
{
    double d = det3(mM);
    double scale = 0;
    for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j)
            scale = std::max(scale, std::fabs(mM[i * 4 + j]));
    return !std::isfinite(d) || std::fabs(d) <= 1e-30 * scale * scale * scale || scale == 0;
}

Transform Transform::inverse() const
{
    if (isSingular())
        throw Error("transform is singular (zero scale?)");
    const auto& m = mM;
    double d = det3(m);
    Transform inv;
    auto& r = inv.mM;
    // Inverse of the 3x3 linear part by cofactors, then the translation.
    r[0] = (m[5] * m[10] - m[6] * m[9]) / d;
    r[1] = (m[2] * m[9] - m[1] * m[10]) / d;
    r[2] = (m[1] * m[6] - m[2] * m[5]) / d;
    r[4] = (m[6] * m[8] - m[4] * m[10]) / d;
    r[5] = (m[0] * m[10] - m[2] * m[8]) / d;
    r[6] = (m[2] * m[4] - m[0] * m[6]) / d;
    r[8] = (m[4] * m[9] - m[5] * m[8]) / d;
    r[9] = (m[1] * m[8] - m[0] * m[9]) / d;
    r[10] = (m[0] * m[5] - m[1] * m[4]) / d;
    for (int i = 0; i < 3; ++i)
        r[i * 4 + 3] = -(r[i * 4 + 0] * m[3] + r[i * 4 + 1] * m[7] + r[i * 4 + 2] * m[11]);
    r[12] = r[13] = r[14] = 0;
    r[15] = 1;
    return inv;
}

float3 Transform::point(float3 p) const
{
    const auto& m = mM;
    return make_float3(float(m[0] * p.x + m[1] * p.y + m[2] * p.z + m[3]),
                       float(m[4] * p.x + m[5] * p.y + m[6] * p.z + m[7]),
                       float(m[8] * p.x + m[9] * p.y + m[10] * p.z + m[11]));
}

float3 Transform::vector(float3 v) const
{
    const auto& m = mM;
    return make_float3(float(m[0] * v.x + m[1] * v.y + m[2] * v.z), float(m[4] * v.x + m[5] * v.y + m[6] * v.z),
                       float(m[8] * v.x + m[9] * v.y + m[10] * v.z));
}

Bbox Transform::box(const Bbox& b) const
{
    Bbox out;
    if (b.empty())
        return out;
    for (int i = 0; i < 8; ++i)
        out.expand(point(make_float3(i & 1 ? b.hi.x : b.lo.x, i & 2 ? b.hi.y : b.lo.y, i & 4 ? b.hi.z : b.lo.z)));
    return out;
}

}  // namespace nimbus
