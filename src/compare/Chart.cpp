// Chart.cpp: the log-log chart of error against time (Compare.h), rasterised here into an
// OIIO ImageBuf: axes with decade ticks, the path tracer's seed-averaged curve (with every seed
// as a dot), WKB's runs as markers coloured by source model and kernel. Text goes through
// OIIO's render_text (its default font); without a font the chart is drawn without labels.
#include "Compare.h"

#include "../core/Error.h"
#include "../core/Log.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <map>

namespace nimbus {

namespace {

struct Canvas {
    OIIO::ImageBuf buf;
    int w, h;
    Canvas(int w_, int h_) : buf(OIIO::ImageSpec(w_, h_, 3, OIIO::TypeDesc::FLOAT)), w(w_), h(h_)
    {
        OIIO::ImageBufAlgo::fill(buf, {1.0f, 1.0f, 1.0f});
    }
    void dot(int x, int y, const float* c)
    {
        if (x >= 0 && y >= 0 && x < w && y < h)
            buf.setpixel(x, y, c, 3);
    }
    void disc(double x, double y, double r, const float* c, bool hollow = false)
    {
        for (int j = int(y - r - 1); j <= int(y + r + 1); ++j)
            for (int i = int(x - r - 1); i <= int(x + r + 1); ++i) {
                const double d = std::hypot(i - x, j - y);
                if (d <= r && (!hollow || d >= r - 1.5))
                    dot(i, j, c);
            }
    }
    void line(double x0, double y0, double x1, double y1, const float* c, int width = 1)
    {
        const int n = int(std::max(std::fabs(x1 - x0), std::fabs(y1 - y0))) + 1;
        for (int k = 0; k <= n; ++k) {
            const double t = double(k) / n;
            const double x = x0 + t * (x1 - x0), y = y0 + t * (y1 - y0);
            for (int a = 0; a < width; ++a)
                for (int b = 0; b < width; ++b)
                    dot(int(std::lround(x)) + a - width / 2, int(std::lround(y)) + b - width / 2, c);
        }
    }
    bool text(int x, int y, const std::string& s, int size = 14, const float* c = nullptr)
    {
        static const float black[3] = {0, 0, 0};
        const float* col = c ? c : black;
        static const std::string font = [] {
            for (const char* f : {"/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
                                  "/usr/share/fonts/dejavu/DejaVuSans.ttf", "/usr/share/fonts/TTF/DejaVuSans.ttf"})
                if (std::FILE* fp = std::fopen(f, "rb")) {
                    std::fclose(fp);
                    return std::string(f);
                }
            return std::string();
        }();
        return OIIO::ImageBufAlgo::render_text(buf, x, y, s, size, font, {col[0], col[1], col[2]});
    }
};

std::string tickLabel(int e)
{
    if (e >= 0 && e <= 3)
        return std::to_string(int(std::lround(std::pow(10.0, e))));
    if (e == -1)
        return "0.1";
    if (e == -2)
        return "0.01";
    return "1e" + std::to_string(e);
}

}  // namespace

void writeErrorChart(const std::vector<CompareRow>& rows, const std::string& path, const std::string& title)
{
    const int W = 900, H = 560, left = 90, right = 260, top = 40, bottom = 60;
    Canvas cv(W, H);
    double tMin = 1e30, tMax = 0, eMin = 1e30, eMax = 0;
    for (const CompareRow& r : rows)
        if (r.seconds > 0 && r.beauty.relMse > 0) {
            tMin = std::min(tMin, r.seconds), tMax = std::max(tMax, r.seconds);
            eMin = std::min(eMin, r.beauty.relMse), eMax = std::max(eMax, r.beauty.relMse);
        }
    if (tMax <= 0) {
        tMin = 0.1, tMax = 10, eMin = 1e-3, eMax = 1;
    }
    const int tx0 = int(std::floor(std::log10(tMin))), tx1 = std::max(tx0 + 1, int(std::ceil(std::log10(tMax))));
    const int ey0 = int(std::floor(std::log10(eMin))), ey1 = std::max(ey0 + 1, int(std::ceil(std::log10(eMax))));
    const double pw = W - left - right, ph = H - top - bottom;
    auto X = [&](double t) { return left + (std::log10(t) - tx0) / (tx1 - tx0) * pw; };
    auto Y = [&](double e) { return top + ph - (std::log10(e) - ey0) / (ey1 - ey0) * ph; };

    const float grey[3] = {0.85f, 0.85f, 0.85f}, black[3] = {0, 0, 0};
    bool fonts = true;
    for (int e = tx0; e <= tx1; ++e) {
        for (int m = 2; m < 10 && e < tx1; ++m)
            cv.line(X(m * std::pow(10.0, e)), top, X(m * std::pow(10.0, e)), top + ph, grey);
        cv.line(X(std::pow(10.0, e)), top, X(std::pow(10.0, e)), top + ph + 6, black);
        fonts = cv.text(int(X(std::pow(10.0, e))) - 12, int(top + ph + 24), tickLabel(e)) && fonts;
    }
    for (int e = ey0; e <= ey1; ++e) {
        for (int m = 2; m < 10 && e < ey1; ++m)
            cv.line(left, Y(m * std::pow(10.0, e)), left + pw, Y(m * std::pow(10.0, e)), grey);
        cv.line(left - 6, Y(std::pow(10.0, e)), left + pw, Y(std::pow(10.0, e)), black);
        cv.text(left - 60, int(Y(std::pow(10.0, e))) + 5, tickLabel(e));
    }
    cv.line(left, top, left, top + ph, black, 2);
    cv.line(left, top + ph, left + pw, top + ph, black, 2);
    cv.text(int(left + pw / 2 - 60), H - 12, "render time (s)", 16);
    cv.text(10, top - 14, "beauty relMSE vs reference    " + title, 16);

    // The path tracer: seed average per ladder step (line) and every seed (small dots).
    const float blue[3] = {0.12f, 0.35f, 0.8f};
    std::map<std::string, std::pair<double, double>> sum;
    std::map<std::string, int> count;
    for (const CompareRow& r : rows)
        if (r.method == "pathtrace" && r.label.rfind("t=", 0) == 0) {
            cv.disc(X(r.seconds), Y(r.beauty.relMse), 2, blue);
            sum[r.label].first += r.seconds, sum[r.label].second += r.beauty.relMse, ++count[r.label];
        }
    std::vector<std::pair<double, double>> avg;
    for (auto& [l, s] : sum)
        avg.push_back({s.first / count[l], s.second / count[l]});
    std::sort(avg.begin(), avg.end());
    for (size_t i = 0; i + 1 < avg.size(); ++i)
        cv.line(X(avg[i].first), Y(avg[i].second), X(avg[i + 1].first), Y(avg[i + 1].second), blue, 2);
    for (auto& p : avg)
        cv.disc(X(p.first), Y(p.second), 4, blue);

    // WKB and single.
    const std::map<std::string, std::array<float, 3>> colours = {{"straight/gaussian", {0.9f, 0.45f, 0.05f}},
                                                                 {"straight/exact", {0.8f, 0.1f, 0.1f}},
                                                                 {"random_walk/gaussian", {0.1f, 0.6f, 0.2f}},
                                                                 {"random_walk/exact", {0.55f, 0.2f, 0.7f}}};
    const float dark[3] = {0.3f, 0.3f, 0.3f};
    for (const CompareRow& r : rows) {
        if (r.method == "wkb") {
            const auto it = colours.find(r.source + "/" + r.kernel);
            const float* c = it != colours.end() ? it->second.data() : dark;
            cv.disc(X(r.seconds), Y(r.beauty.relMse), r.label == "base" ? 6 : 5, c, r.label != "base");
        } else if (r.method == "single") {
            cv.disc(X(r.seconds), Y(r.beauty.relMse), 5, dark);
        }
    }
    // Legend.
    int ly = top + 10;
    const int lx = W - right + 20;
    cv.disc(lx, ly - 5, 4, blue);
    cv.text(lx + 12, ly, "path tracer (mean of seeds)");
    ly += 24;
    for (const auto& [name, c] : colours) {
        cv.disc(lx, ly - 5, 6, c.data());
        cv.text(lx + 12, ly, "wkb " + name);
        ly += 24;
    }
    cv.disc(lx, ly - 5, 5, dark, true);
    cv.text(lx + 12, ly, "wkb quality ladder (hollow)");
    ly += 24;
    cv.disc(lx, ly - 5, 5, dark);
    cv.text(lx + 12, ly, "single (L0 + L1 only)");
    if (!fonts)
        logWarning("compare: no font for chart labels; " + path + " has none");

    OIIO::ImageBuf out(OIIO::ImageSpec(W, H, 3, OIIO::TypeDesc::UINT8));
    out.copy_pixels(cv.buf);
    if (!out.write(path))
        throw Error("compare: cannot write " + path + ": " + out.geterror());
}

}  // namespace nimbus
