// Transform.h: affine transforms, named by what they map (worldFromVolume, cameraFromWorld).
#pragma once

#include "Vec.h"

#include <array>

namespace nimbus {

// A 4x4 affine matrix in double precision (composition of VDB index-to-world transforms with
// user transforms keeps its accuracy at kilometre scales with millimetre voxels), applied in float.
class Transform {
public:
    Transform();  // identity
    static Transform fromRowMajor(const std::array<double, 16>& m);
    static Transform translate(double x, double y, double z);
    static Transform scale(double x, double y, double z);
    static Transform rotateDegrees(double angle, double ax, double ay, double az);

    Transform operator*(const Transform& rhs) const;  // this after rhs
    Transform inverse() const;                        // throws if singular
    bool isSingular() const;

    float3 point(float3 p) const;
    float3 vector(float3 v) const;
    Bbox box(const Bbox& b) const;  // bound of the eight transformed corners

    double at(int row, int col) const { return mM[row * 4 + col]; }
    const std::array<double, 16>& rowMajor() const { return mM; }

private:
    std::array<double, 16> mM;
};

}  // namespace nimbus
