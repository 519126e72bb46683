#include "PathtraceState.h"

#include "../../kernels/shared/ptscene.h"

#include <algorithm>
#include <cmath>

namespace nimbus {

namespace {

// The accumulator's fixed part as AOVs: name, channels, first accumulator float.
struct StateSlot {
    const char* name;
    int channels;
    int offset;
};
constexpr StateSlot kFixedSlots[] = {
    {"L0", 3, NB_ACC_L0},
    {"L1", 3, NB_ACC_L1},
    {"L2plus", 3, NB_ACC_L2},
    {"transmittance", 1, NB_ACC_TRANSMITTANCE},
    {"depth_sum", 1, NB_ACC_DEPTH_SUM},
    {"depth_hits", 1, NB_ACC_DEPTH_HITS},
    {"mean_y", 1, NB_ACC_MEAN_Y},
    {"m2_y", 1, NB_ACC_M2_Y},
};

// Every slot with its offset: the fixed ones, then 3 floats per light.
std::vector<StateSlot> slots(const std::vector<std::string>& lightAovs, std::vector<std::string>& names)
{
    std::vector<StateSlot> out(std::begin(kFixedSlots), std::end(kFixedSlots));
    names.clear();
    for (const StateSlot& s : out)
        names.push_back(std::string(kStateAovPrefix) + s.name);
    for (size_t i = 0; i < lightAovs.size(); ++i) {
        out.push_back({nullptr, 3, NB_ACC_LIGHTS + 3 * int(i)});
        names.push_back(std::string(kStateAovPrefix) + lightAovs[i]);
    }
    return out;
}

}  // namespace

bool isStateAov(const std::string& name)
{
    return name.rfind(kStateAovPrefix, 0) == 0;
}

int stateStride(size_t lightCount)
{
    return NB_ACC_STRIDE(int(lightCount));
}

std::vector<std::pair<std::string, int>> stateAovLayout(const std::vector<std::string>& lightAovs)
{
    std::vector<std::string> names;
    const std::vector<StateSlot> s = slots(lightAovs, names);
    std::vector<std::pair<std::string, int>> out;
    for (size_t i = 0; i < s.size(); ++i)
        out.push_back({names[i], s[i].channels});
    return out;
}

void addStateAovs(Film& film, const std::vector<std::string>& lightAovs)
{
    for (const auto& [name, channels] : stateAovLayout(lightAovs))
        film.add(name, channels, true);
}

void dropStateAovs(Film& film)
{
    film.aovs.erase(std::remove_if(film.aovs.begin(), film.aovs.end(), [](const Aov& a) { return isStateAov(a.name); }),
                    film.aovs.end());
}

bool readState(const Film& film, const std::vector<std::string>& lightAovs, std::vector<float>& acc)
{
    std::vector<std::string> names;
    const std::vector<StateSlot> s = slots(lightAovs, names);
    std::vector<const Aov*> aovs;
    for (size_t i = 0; i < s.size(); ++i) {
        const Aov* a = film.find(names[i]);
        if (!a || a->channels != s[i].channels)
            return false;
        aovs.push_back(a);
    }
    const int stride = stateStride(lightAovs.size()), cropWidth = film.x1 - film.x0;
    acc.assign(size_t(cropWidth) * size_t(film.y1 - film.y0) * stride, 0.0f);
    for (int y = film.y0; y < film.y1; ++y)
        for (int x = film.x0; x < film.x1; ++x) {
            float* a = acc.data() + (size_t(y - film.y0) * cropWidth + (x - film.x0)) * stride;
            const size_t pixel = size_t(y) * film.width + x;
            for (size_t i = 0; i < s.size(); ++i)
                for (int c = 0; c < s[i].channels; ++c)
                    a[s[i].offset + c] = aovs[i]->pixels[pixel * s[i].channels + c];
        }
    return true;
}

void resolveState(const std::vector<float>& acc, long long n, const std::vector<std::string>& lightAovs, Film& film)
{
    Aov* beauty = film.find("beauty");
    Aov* L[3] = {film.find("L0"), film.find("L1"), film.find("L2plus")};
    Aov* alpha = film.find("alpha");
    Aov* depth = film.find("depth");
    Aov* variance = film.find("variance");
    std::vector<Aov*> lightAov;
    for (const std::string& name : lightAovs)
        lightAov.push_back(film.find(name));
    std::vector<std::string> names;
    const std::vector<StateSlot> s = slots(lightAovs, names);
    std::vector<Aov*> stateAov;
    for (const std::string& name : names)
        stateAov.push_back(film.find(name));
    const int stride = stateStride(lightAovs.size()), cropWidth = film.x1 - film.x0;
    const double varianceScale = n > 1 ? 1.0 / (double(n) * double(n - 1)) : 0.0;
    for (int y = film.y0; y < film.y1; ++y)
        for (int x = film.x0; x < film.x1; ++x) {
            const float* a = acc.data() + (size_t(y - film.y0) * cropWidth + (x - film.x0)) * stride;
            float b[3] = {0, 0, 0};
            for (int k = 0; k < 3; ++k) {
                for (int c = 0; c < 3; ++c)
                    b[c] += a[3 * k + c];
                if (L[k]) {
                    float* p = film.pixel(*L[k], x, y);
                    p[0] = a[3 * k], p[1] = a[3 * k + 1], p[2] = a[3 * k + 2];
                }
            }
            const float al = 1.0f - a[NB_ACC_TRANSMITTANCE];
            if (beauty) {
                float* p = film.pixel(*beauty, x, y);
                p[0] = b[0], p[1] = b[1], p[2] = b[2];
                if (beauty->channels == 4)
                    p[3] = al;
            }
            if (alpha)
                *film.pixel(*alpha, x, y) = al;
            if (depth)
                *film.pixel(*depth, x, y) =
                    a[NB_ACC_DEPTH_HITS] > 0 ? a[NB_ACC_DEPTH_SUM] / a[NB_ACC_DEPTH_HITS] : 0.0f;
            if (variance)
                *film.pixel(*variance, x, y) = float(double(a[NB_ACC_M2_Y]) * varianceScale);
            for (size_t i = 0; i < lightAov.size(); ++i)
                if (lightAov[i]) {
                    float* p = film.pixel(*lightAov[i], x, y);
                    const float* q = a + NB_ACC_LIGHTS + 3 * i;
                    p[0] = q[0], p[1] = q[1], p[2] = q[2];
                }
            for (size_t i = 0; i < s.size(); ++i)
                if (stateAov[i] && stateAov[i]->channels == s[i].channels) {
                    float* p = film.pixel(*stateAov[i], x, y);
                    for (int c = 0; c < s[i].channels; ++c)
                        p[c] = a[s[i].offset + c];
                }
        }
}

std::vector<float> poolStates(const std::vector<StatePart>& parts, size_t lightCount, long long& total)
{
    total = 0;
    for (const StatePart& p : parts)
        total += p.n;
    if (parts.empty() || total <= 0)
        return {};
    const int stride = stateStride(lightCount);
    const size_t size = parts.front().acc->size(), pixels = size / size_t(stride);
    std::vector<float> out(size, 0.0f);
    std::vector<double> sum(static_cast<size_t>(stride));
    for (size_t pixel = 0; pixel < pixels; ++pixel) {
        const size_t base = pixel * size_t(stride);
        std::fill(sum.begin(), sum.end(), 0.0);
        // Every running mean pools weighted by its sample count.
        for (const StatePart& p : parts)
            for (int k = 0; k < stride; ++k)
                if (k != NB_ACC_M2_Y)
                    sum[size_t(k)] += double(p.n) * double((*p.acc)[base + size_t(k)]);
        for (int k = 0; k < stride; ++k)
            sum[size_t(k)] /= double(total);
        // M2 pools with the spread of the parts' means about the pooled mean.
        const double mean = sum[NB_ACC_MEAN_Y];
        double m2 = 0;
        for (const StatePart& p : parts) {
            const double d = double((*p.acc)[base + NB_ACC_MEAN_Y]) - mean;
            m2 += double((*p.acc)[base + NB_ACC_M2_Y]) + double(p.n) * d * d;
        }
        sum[NB_ACC_M2_Y] = m2;
        for (int k = 0; k < stride; ++k)
            out[base + size_t(k)] = float(sum[size_t(k)]);
    }
    return out;
}

double stateNoiseRelMse(const std::vector<float>& acc, int stride, long long n)
{
    const size_t pixels = acc.size() / size_t(stride);
    if (pixels == 0 || n < 2)
        return INFINITY;
    double mean = 0;
    for (size_t i = 0; i < pixels; ++i)
        mean += acc[i * stride + NB_ACC_MEAN_Y];
    mean /= double(pixels);
    const double eps = 0.01 * mean * mean + 1e-20, varianceScale = 1.0 / (double(n) * double(n - 1));
    double sum = 0;
    for (size_t i = 0; i < pixels; ++i) {
        const double y = acc[i * stride + NB_ACC_MEAN_Y];
        sum += double(acc[i * stride + NB_ACC_M2_Y]) * varianceScale / (y * y + eps);
    }
    return sum / double(pixels);
}

}  // namespace nimbus
