#include "Animation.h"

#include <algorithm>
#include <cmath>

namespace nimbus {

namespace {

// The key interval holding `frame` and the fraction through it; hold outside the keys.
struct Bracket {
    size_t a, b;
    double u;
};

template <class T>
Bracket bracket(const Keys<T>& k, double frame)
{
    const size_t n = k.frames.size();
    if (n == 1 || !(frame > k.frames.front()))
        return {0, 0, 0.0};
    if (frame >= k.frames.back())
        return {n - 1, n - 1, 0.0};
    const size_t b = size_t(std::upper_bound(k.frames.begin(), k.frames.end(), frame) - k.frames.begin());
    const size_t a = b - 1;
    return {a, b, (frame - k.frames[a]) / (k.frames[b] - k.frames[a])};
}

void quatFromMatrix(const double r[3][3], double q[4])
{
    // Shepperd's method: the largest of w, x, y, z first, so no square root of a small number.
    const double tr = r[0][0] + r[1][1] + r[2][2];
    if (tr > 0.0) {
        const double s = 2.0 * std::sqrt(1.0 + tr);
        q[0] = 0.25 * s, q[1] = (r[2][1] - r[1][2]) / s, q[2] = (r[0][2] - r[2][0]) / s, q[3] = (r[1][0] - r[0][1]) / s;
    } else if (r[0][0] > r[1][1] && r[0][0] > r[2][2]) {
        const double s = 2.0 * std::sqrt(1.0 + r[0][0] - r[1][1] - r[2][2]);
        q[0] = (r[2][1] - r[1][2]) / s, q[1] = 0.25 * s, q[2] = (r[0][1] + r[1][0]) / s, q[3] = (r[0][2] + r[2][0]) / s;
    } else if (r[1][1] > r[2][2]) {
        const double s = 2.0 * std::sqrt(1.0 + r[1][1] - r[0][0] - r[2][2]);
        q[0] = (r[0][2] - r[2][0]) / s, q[1] = (r[0][1] + r[1][0]) / s, q[2] = 0.25 * s, q[3] = (r[1][2] + r[2][1]) / s;
    } else {
        const double s = 2.0 * std::sqrt(1.0 + r[2][2] - r[0][0] - r[1][1]);
        q[0] = (r[1][0] - r[0][1]) / s, q[1] = (r[0][2] + r[2][0]) / s, q[2] = (r[1][2] + r[2][1]) / s, q[3] = 0.25 * s;
    }
    const double n = std::sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
    for (int i = 0; i < 4; ++i)
        q[i] /= n;
}

void matrixFromQuat(const double q[4], double r[3][3])
{
    const double w = q[0], x = q[1], y = q[2], z = q[3];
    r[0][0] = 1 - 2 * (y * y + z * z), r[0][1] = 2 * (x * y - w * z), r[0][2] = 2 * (x * z + w * y);
    r[1][0] = 2 * (x * y + w * z), r[1][1] = 1 - 2 * (x * x + z * z), r[1][2] = 2 * (y * z - w * x);
    r[2][0] = 2 * (x * z - w * y), r[2][1] = 2 * (y * z + w * x), r[2][2] = 1 - 2 * (x * x + y * y);
}

// Spherical linear interpolation along the shorter arc.
void slerp(const double a[4], const double bIn[4], double u, double out[4])
{
    double b[4] = {bIn[0], bIn[1], bIn[2], bIn[3]};
    double c = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    if (c < 0.0) {
        c = -c;
        for (double& v : b)
            v = -v;
    }
    double wa, wb;
    if (c > 1.0 - 1e-12) {  // nearly equal: linear, then normalised
        wa = 1.0 - u, wb = u;
    } else {
        const double theta = std::acos(std::min(1.0, c));
        const double s = std::sin(theta);
        wa = std::sin((1.0 - u) * theta) / s, wb = std::sin(u * theta) / s;
    }
    double n = 0.0;
    for (int i = 0; i < 4; ++i) {
        out[i] = wa * a[i] + wb * b[i];
        n += out[i] * out[i];
    }
    n = std::sqrt(n);
    for (int i = 0; i < 4; ++i)
        out[i] /= n;
}

}  // namespace

float3 evaluateKeys(const Keys<float3>& keys, double frame)
{
    const Bracket k = bracket(keys, frame);
    const float3 a = keys.values[k.a], b = keys.values[k.b];
    const float u = float(k.u);
    return a + (b - a) * u;
}

float evaluateKeys(const Keys<float>& keys, double frame)
{
    const Bracket k = bracket(keys, frame);
    return float(double(keys.values[k.a]) + (double(keys.values[k.b]) - double(keys.values[k.a])) * k.u);
}

TrsParts splitTrs(const Transform& t)
{
    if (t.at(3, 0) != 0.0 || t.at(3, 1) != 0.0 || t.at(3, 2) != 0.0 || t.at(3, 3) != 1.0)
        throw std::invalid_argument("a transform key must be affine (last row 0 0 0 1)");
    TrsParts p;
    double r[3][3];
    for (int col = 0; col < 3; ++col) {
        const double x = t.at(0, col), y = t.at(1, col), z = t.at(2, col);
        const double s = std::sqrt(x * x + y * y + z * z);
        if (!(s > 0.0) || !std::isfinite(s))
            throw std::invalid_argument("a transform key has a zero or non-finite scale");
        p.scale[col] = s;
        r[0][col] = x / s, r[1][col] = y / s, r[2][col] = z / s;
        p.translate[col] = t.at(col, 3);
    }
    // The columns must be orthogonal (no shear) for T R S to hold.
    for (int i = 0; i < 3; ++i)
        for (int j = i + 1; j < 3; ++j) {
            const double d = r[0][i] * r[0][j] + r[1][i] * r[1][j] + r[2][i] * r[2][j];
            if (std::abs(d) > 1e-5)
                throw std::invalid_argument("a transform key has shear (not translate x rotate x scale)");
        }
    const double det = r[0][0] * (r[1][1] * r[2][2] - r[1][2] * r[2][1]) -
                       r[0][1] * (r[1][0] * r[2][2] - r[1][2] * r[2][0]) +
                       r[0][2] * (r[1][0] * r[2][1] - r[1][1] * r[2][0]);
    if (det < 0.0) {  // a mirror: carried by a negative x scale, the rest is a rotation
        p.scale[0] = -p.scale[0];
        for (int i = 0; i < 3; ++i)
            r[i][0] = -r[i][0];
    }
    quatFromMatrix(r, p.rotation);
    return p;
}

Transform composeTrs(const TrsParts& p)
{
    double r[3][3];
    matrixFromQuat(p.rotation, r);
    std::array<double, 16> m{};
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j)
            m[size_t(i * 4 + j)] = r[i][j] * p.scale[j];
        m[size_t(i * 4 + 3)] = p.translate[i];
    }
    m[15] = 1.0;
    return Transform::fromRowMajor(m);
}

Transform evaluateKeys(const Keys<Transform>& keys, double frame)
{
    const Bracket k = bracket(keys, frame);
    if (k.a == k.b || k.u == 0.0)
        return keys.values[k.a];
    const TrsParts a = splitTrs(keys.values[k.a]), b = splitTrs(keys.values[k.b]);
    TrsParts p;
    for (int i = 0; i < 3; ++i) {
        p.translate[i] = a.translate[i] + (b.translate[i] - a.translate[i]) * k.u;
        p.scale[i] = a.scale[i] + (b.scale[i] - a.scale[i]) * k.u;
    }
    slerp(a.rotation, b.rotation, k.u, p.rotation);
    return composeTrs(p);
}

}  // namespace nimbus
