// The shared kernel code compiled by the OpenCL compiler agrees with the host build: a
// chi-square test of HG and two-lobe HG sampling run inside a kernel, and the OpenCL port of the
// brick grid against BrickGrid. Also the OpenCL plumbing: device selection errors, build
// errors reported in one line, and the binary cache.
#include "../TestDir.h"
#include "PtWorld.h"

#include "../../kernels/shared/brickgrid.h"
#include "../../kernels/shared/rng.h"

#include "core/Error.h"
#include "pathtracer/KernelCache.h"
#include "pathtracer/OpenCl.h"

#include <boost/math/distributions/chi_squared.hpp>
#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <random>

using namespace nimbus;
using namespace nimbus::pttest;

namespace {

const std::string kTestKernel = std::string(NIMBUS_TEST_DIR) + "/phase_sample.cl";

struct DeviceSamples {
    std::vector<float> cosines, directions;
};

DeviceSamples samplePhaseOnDevice(const ocl::Context& cl, cl_program program, NbPhase p, float3 wi, size_t n)
{
    cl_int err = CL_SUCCESS;
    ocl::Kernel k(clCreateKernel(program, "samplePhase", &err));
    ocl::check(err, "clCreateKernel(samplePhase)");
    ocl::Mem cosBuf = cl.allocate(n * sizeof(float)), dirBuf = cl.allocate(3 * n * sizeof(float));
    cl_mem c = cosBuf.get(), d = dirBuf.get();
    ocl::check(clSetKernelArg(k.get(), 0, sizeof p, &p), "arg");
    ocl::check(clSetKernelArg(k.get(), 1, sizeof(float), &wi.x), "arg");
    ocl::check(clSetKernelArg(k.get(), 2, sizeof(float), &wi.y), "arg");
    ocl::check(clSetKernelArg(k.get(), 3, sizeof(float), &wi.z), "arg");
    ocl::check(clSetKernelArg(k.get(), 4, sizeof(cl_mem), &c), "arg");
    ocl::check(clSetKernelArg(k.get(), 5, sizeof(cl_mem), &d), "arg");
    ocl::check(clEnqueueNDRangeKernel(cl.queue(), k.get(), 1, nullptr, &n, nullptr, 0, nullptr, nullptr), "launch");
    DeviceSamples out;
    out.cosines.resize(n);
    out.directions.resize(3 * n);
    cl.read(cosBuf, out.cosines.data(), n * sizeof(float));
    cl.read(dirBuf, out.directions.data(), 3 * n * sizeof(float));
    return out;
}

// Chi-square p-value of sampled cosines against nbPhaseEval integrated over bins (the binning
// of tests/core/test_phase.cpp: t = sqrt((1 - side*mu)/2), dense near the lobe's peak).
double chiSquarePValue(const std::vector<float>& cosines, NbPhase p, double side, double* chi2Out, int* dofOut)
{
    const int bins = 64;
    std::vector<double> observed(bins, 0.0), expected(bins, 0.0);
    for (float c : cosines) {
        double mu = side * std::min(1.0, std::max(-1.0, double(c)));
        int b = std::min(bins - 1, int(std::sqrt((1.0 - mu) / 2.0) * bins));
        observed[b] += 1;
    }
    for (int b = 0; b < bins; ++b) {
        double t0 = double(b) / bins, t1 = double(b + 1) / bins;
        double mu0 = 1 - 2 * t1 * t1, mu1 = 1 - 2 * t0 * t0;
        const int m = 400;
        double integral = 0;
        for (int i = 0; i < m; ++i) {
            double mu = mu0 + (i + 0.5) * (mu1 - mu0) / m;
            integral += 2 * M_PI * nbPhaseEval(p, float(side * mu)) * (mu1 - mu0) / m;
        }
        expected[b] = integral * double(cosines.size());
    }
    double chi2 = 0, pooledO = 0, pooledE = 0;
    int dof = -1;
    for (int b = 0; b < bins; ++b) {
        pooledO += observed[b];
        pooledE += expected[b];
        if (pooledE >= 5) {  // Cochran's rule: pool bins with small expectations
            chi2 += (pooledO - pooledE) * (pooledO - pooledE) / pooledE;
            pooledO = pooledE = 0;
            ++dof;
        }
    }
    *chi2Out = chi2;
    *dofOut = dof;
    return 1.0 - boost::math::cdf(boost::math::chi_squared(dof), chi2);
}

}  // namespace

class DevicePhase : public ::testing::TestWithParam<NbPhase> {};

// Samples drawn by nbPhaseSample compiled for the OpenCL device follow nbPhaseEval (host), and
// reproduce the host build's samples from the same random numbers.
TEST_P(DevicePhase, SamplerMatchesEvaluatorChiSquare)
{
    useTestKernelCache("device");
    const NbPhase p = GetParam();
    ocl::Context cl(ocl::selectDevice(""));
    ProgramBuild build = buildProgram(cl, kTestKernel, "");
    const size_t n = 400000;
    const float3 wi = normalize(make_float3(0.3f, -0.5f, 0.8f));
    DeviceSamples s = samplePhaseOnDevice(cl, build.program.get(), p, wi, n);

    double chi2 = 0;
    int dof = 0;
    const double side = nbPhaseMeanCos(p) < 0 ? -1.0 : 1.0;
    double pValue = chiSquarePValue(s.cosines, p, side, &chi2, &dof);
    std::printf("device sampling g=%.2f g2=%.2f blend=%.2f: chi2 %.1f dof %d p %.3f\n", p.g, p.g2, p.blend, chi2, dof,
                pValue);
    EXPECT_GT(pValue, 1e-3) << "chi2 " << chi2 << " dof " << dof;

    // Same random numbers, same code: the device and host directions agree to float rounding
    // (transcendentals may differ by a few ulps between the two builds).
    double worst = 0;
    for (size_t i = 0; i < n; ++i) {
        NbRng r = nbRngStart(7u, 0u, nb_uint(i));
        float u0 = nbRngNext(&r), u1 = nbRngNext(&r), u2 = nbRngNext(&r);
        float3 wo = nbPhaseSample(p, wi, u0, u1, u2);
        worst = std::max(worst, double(length(wo - make_float3(s.directions[3 * i], s.directions[3 * i + 1],
                                                               s.directions[3 * i + 2]))));
    }
    std::printf("largest host/device direction difference: %.2e\n", worst);
    EXPECT_LT(worst, 2e-3);
}

INSTANTIATE_TEST_SUITE_P(Lobes, DevicePhase,
                         ::testing::Values(NbPhase{0.0f, 0, 0, 0}, NbPhase{0.5f, 0, 0, 0}, NbPhase{0.9f, 0, 0, 0},
                                           NbPhase{-0.7f, 0, 0, 0}, NbPhase{0.99f, 0, 0, 0},
                                           NbPhase{0.8f, -0.4f, 0.3f, 0}, NbPhase{0.9f, -0.6f, 0.5f, 0}),
                         [](const ::testing::TestParamInfo<NbPhase>& i) {
                             auto f = [](float v) {
                                 std::string s = std::to_string(int(std::lround(100 * v)));
                                 return s[0] == '-' ? "m" + s.substr(1) : s;
                             };
                             std::string name = "g" + f(i.param.g);
                             if (i.param.blend > 0)
                                 name += "_g2" + f(i.param.g2) + "_w" + f(i.param.blend);
                             return name;
                         });

// The OpenCL port of the brick grid (kernels/shared/brickgrid.h) reads BrickGrid's arrays as
// BrickGrid does: the same values at random points, inside, on brick faces and outside, on the
// device and in the host build of the same header.
TEST(DeviceGrid, PortMatchesBrickGrid)
{
    useTestKernelCache("device");
    std::mt19937 rng(5);
    std::uniform_real_distribution<float> value(0.0f, 3.0f);
    std::vector<float> field(40 * 40 * 40 * 3);
    for (float& v : field)
        v = value(rng);
    BrickGrid g = gridFrom({4, 3, 2}, 3, [&](int i, int j, int k, int c) {
        if ((i / 8 + j / 8 + k / 8) % 3 == 1)
            return 0.0f;  // some empty bricks
        return field[((size_t(k) * 40 + j) * 40 + i) * 3 + c];
    });
    ASSERT_GT(g.brickCount(), 5u);
    NbGridDesc d{};
    d.dims[0] = g.dims().x, d.dims[1] = g.dims().y, d.dims[2] = g.dims().z, d.dims[3] = 3;
    d.maxValue = g.maxValue();

    std::uniform_real_distribution<float> px(-3.0f, 36.0f), py(-3.0f, 27.0f), pz(-3.0f, 19.0f);
    const size_t n = 20000;
    std::vector<float> points(3 * n);
    for (size_t i = 0; i < n; ++i) {
        points[3 * i] = px(rng), points[3 * i + 1] = py(rng), points[3 * i + 2] = pz(rng);
        if (i % 7 == 0)
            points[3 * i] = float(8 * (i % 5));  // exactly on a brick face
    }

    ocl::Context cl(ocl::selectDevice(""));
    ProgramBuild build = buildProgram(cl, kTestKernel, "");
    cl_int err = CL_SUCCESS;
    ocl::Kernel k(clCreateKernel(build.program.get(), "sampleGrid", &err));
    ocl::check(err, "clCreateKernel(sampleGrid)");
    ocl::Mem tb = cl.upload(g.table()), pb = cl.upload(g.pool()), ptb = cl.upload(points),
             vb = cl.allocate(3 * n * sizeof(float));
    cl_mem a[] = {tb.get(), pb.get(), ptb.get(), vb.get()};
    ocl::check(clSetKernelArg(k.get(), 0, sizeof d, &d), "arg");
    for (cl_uint i = 0; i < 4; ++i)
        ocl::check(clSetKernelArg(k.get(), i + 1, sizeof(cl_mem), &a[i]), "arg");
    ocl::check(clEnqueueNDRangeKernel(cl.queue(), k.get(), 1, nullptr, &n, nullptr, 0, nullptr, nullptr), "launch");
    std::vector<float> device(3 * n);
    cl.read(vb, device.data(), device.size() * sizeof(float));

    double worst = 0;
    for (size_t i = 0; i < n; ++i) {
        float3 p = make_float3(points[3 * i], points[3 * i + 1], points[3 * i + 2]);
        float3 hostPort = nbGridSample3(d, g.table().data(), g.pool().data(), p);
        for (int c = 0; c < 3; ++c) {
            float ref = g.sample(p, c);
            ASSERT_EQ(component(hostPort, c), ref) << "host build of the port, point " << i;
            worst = std::max(worst, double(std::fabs(device[3 * i + c] - ref)));
        }
        float m = nbGridMajorant(d, g.majorants().data(), int(std::floor(p.x)) >> 3, int(std::floor(p.y)) >> 3,
                                 int(std::floor(p.z)) >> 3);
        ASSERT_EQ(m, g.majorantAt(p));
    }
    EXPECT_LT(worst, 1e-5);
}

TEST(DeviceSelection, UnknownDeviceIsOneLineError)
{
    try {
        ocl::selectDevice("no-such-device-xyz");
        FAIL() << "expected an Error";
    } catch (const Error& e) {
        std::string m = e.what();
        EXPECT_NE(m.find("no device matches"), std::string::npos) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
    std::vector<std::string> devices = listOpenClDevices();
    ASSERT_FALSE(devices.empty());
    EXPECT_EQ(ocl::selectDevice("0").index, 0);
    std::printf("%s\n", devices[0].c_str());
}

TEST(KernelBuild, CompileErrorIsOneLineWithTheCompilersMessage)
{
    useTestKernelCache("device");
    std::string file = std::string(::testing::TempDir()) + "nimbus_broken_kernel.cl";
    {
        std::ofstream out(file);
        out << "__kernel void broken(__global float* x) { x[0] = undeclared_thing; }\n";
    }
    ocl::Context cl(ocl::selectDevice(""));
    try {
        buildProgram(cl, file, "");
        FAIL() << "expected an Error";
    } catch (const Error& e) {
        std::string m = e.what();
        std::printf("%s\n", m.c_str());
        EXPECT_NE(m.find("undeclared_thing"), std::string::npos) << m;
        EXPECT_EQ(m.find('\n'), std::string::npos) << m;
    }
}

// A second build of the same source and options loads the binary the first one cached.
TEST(KernelBuild, BinaryCacheHitsOnSecondBuild)
{
    useTestKernelCache("device");
    ocl::Context cl(ocl::selectDevice(""));
    const std::string options = "-D NB_CACHE_TEST_TOKEN=" + std::to_string(std::random_device{}());
    ProgramBuild first = buildProgram(cl, kTestKernel, options);
    EXPECT_FALSE(first.fromCache);
    ASSERT_FALSE(first.cacheFile.empty());
    ProgramBuild second = buildProgram(cl, kTestKernel, options);
    EXPECT_TRUE(second.fromCache);
    EXPECT_EQ(first.cacheFile, second.cacheFile);
    std::printf("build %.3f s, cached load %.3f s\n", first.seconds, second.seconds);
    std::remove(first.cacheFile.c_str());
}
