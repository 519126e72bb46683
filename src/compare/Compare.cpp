// Compare.cpp: `nimbus compare` (Compare.h). The reference is cached by a hash of the scene's
// complete JSON document (every key, defaults included) and the reference's time budget.
#include "Compare.h"

#include "../core/Error.h"
#include "../core/Log.h"
#include "../io/AtomicFile.h"
#include "../io/ExrWriter.h"
#include "../io/Preview.h"
#include "../render/Renderer.h"
#include "../scene/SceneJson.h"

#include <OpenImageIO/imagebuf.h>
#include <OpenImageIO/imagebufalgo.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

#include <unistd.h>

namespace nimbus {

namespace fs = std::filesystem;

namespace {

const Aov& requireAov(const Film& f, const std::string& name)
{
    const Aov* a = f.find(name);
    if (!a)
        throw Error("compare: the film has no AOV '" + name + "'");
    return *a;
}

double meanOf(const Aov& a, int n)
{
    double s = 0;
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c)
            s += a.pixels[size_t(i) * size_t(a.channels) + size_t(c)];
    return s / std::max(1, 3 * n);
}

uint64_t fnv1a(const std::string& s)
{
    uint64_t h = 1469598103934665603ull;
    for (unsigned char c : s)
        h = (h ^ c) * 1099511628211ull;
    return h;
}

std::string defaultCacheDir()
{
    if (const char* d = std::getenv("NIMBUS_CACHE_DIR"); d && *d)
        return d;
    if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d)
        return std::string(d) + "/nimbus";
    if (const char* d = std::getenv("HOME"); d && *d)
        return std::string(d) + "/.cache/nimbus";
    return "/tmp/nimbus-cache";
}

// The reference's AOVs that the comparison reads, as a flat binary file (magic, size, AOVs).
const char* kCachedAovs[] = {"beauty", "L0", "L1", "L2plus", "variance"};

void saveReference(const Film& f, const std::string& path)
{
    std::ostringstream o(std::ios::binary);
    o.write("NBCMPREF", 8);
    int32_t hdr[2] = {f.width, f.height};
    o.write(reinterpret_cast<const char*>(hdr), sizeof(hdr));
    for (const char* name : kCachedAovs) {
        const Aov& a = requireAov(f, name);
        int32_t ch = a.channels;
        o.write(reinterpret_cast<const char*>(&ch), sizeof(ch));
        o.write(reinterpret_cast<const char*>(a.pixels.data()), std::streamsize(a.pixels.size() * sizeof(float)));
    }
    fs::create_directories(fs::path(path).parent_path());
    std::string tmp = path + ".tmp" + std::to_string(::getpid());
    {
        std::ofstream out(tmp, std::ios::binary);
        out << o.str();
        if (!out)
            throw Error("compare: cannot write " + tmp);
    }
    fs::rename(tmp, path);
}

bool loadReference(const std::string& path, Film& f)
{
    std::ifstream in(path, std::ios::binary);
    if (!in)
        return false;
    char magic[8];
    int32_t hdr[2];
    if (!in.read(magic, 8) || std::string(magic, 8) != "NBCMPREF" || !in.read(reinterpret_cast<char*>(hdr), sizeof(hdr)))
        return false;
    f = Film{};
    f.width = hdr[0], f.height = hdr[1], f.x1 = hdr[0], f.y1 = hdr[1];
    for (const char* name : kCachedAovs) {
        int32_t ch = 0;
        if (!in.read(reinterpret_cast<char*>(&ch), sizeof(ch)) || ch < 1 || ch > 4)
            return false;
        Aov& a = f.add(name, ch, std::string(name) == "variance");
        a.pixels.resize(size_t(f.width) * size_t(f.height) * size_t(ch));
        if (!in.read(reinterpret_cast<char*>(a.pixels.data()), std::streamsize(a.pixels.size() * sizeof(float))))
            return false;
    }
    return true;
}

std::string fmt(const char* format, double v)
{
    char buf[64];
    std::snprintf(buf, sizeof(buf), format, v);
    return buf;
}

long long sppOf(const Film& f)
{
    for (const auto& kv : f.metadata)
        if (kv.first == "pathtrace_spp")
            return std::atoll(kv.second.c_str());
    return 0;
}

CompareRow makeRow(const std::string& method, const std::string& label, const Scene& s, const RenderResult& r,
                   const Film& ref)
{
    CompareRow row;
    row.method = method;
    row.label = label;
    if (method == "wkb") {
        row.source = wkbSourceName(s.render.wkbSource);
        row.kernel = wkbKernelName(s.render.wkbKernel);
    }
    row.seed = s.render.seed;
    row.seconds = r.seconds;
    row.spp = method == "pathtrace" ? sppOf(r.film) : (s.render.spp > 0 ? s.render.spp : kDefaultMarchSpp);
    row.beauty = measureError(r.film, ref, "beauty");
    row.L1 = measureError(r.film, ref, "L1");
    row.L2plus = r.film.find("L2plus") ? measureError(r.film, ref, "L2plus") : ErrorMetrics{1, 1, -1};
    return row;
}

// Luminance of an AOV's first three channels.
float lum(const Aov& a, size_t i)
{
    const float* p = a.pixels.data() + i * size_t(a.channels);
    return 0.2126f * p[0] + 0.7152f * p[1] + 0.0722f * p[2];
}

// reference | WKB | path tracer at equal time (through the preview transform) | signed
// difference WKB - reference of luminance (blue negative, red positive, full scale = the largest
// |difference|), each panel magnified 4x (nearest pixel).
void writeSheet(const Film& ref, const Film& wkb, const Film& pt, const std::string& path, const std::string& tmpDir)
{
    const int w = ref.width, h = ref.height, n = w * h;
    Film strip;
    strip.width = 3 * w, strip.height = h, strip.x1 = 3 * w, strip.y1 = h;
    Aov& b = strip.add("beauty", 4, false);
    b.pixels.assign(size_t(strip.width) * size_t(h) * 4, 0.0f);
    const Film* panels[3] = {&ref, &wkb, &pt};
    for (int k = 0; k < 3; ++k) {
        const Aov& a = requireAov(*panels[k], "beauty");
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                const float* p = a.pixels.data() + (size_t(y) * w + x) * size_t(a.channels);
                float* q = strip.pixel(b, k * w + x, y);
                q[0] = p[0], q[1] = p[1], q[2] = p[2], q[3] = 1.0f;
            }
    }
    const std::string tmp = tmpDir + "/.sheet-strip.png";
    writePreview(strip, tmp);
    OIIO::ImageBuf in(tmp);
    if (!in.read(0, 0, true, OIIO::TypeDesc::FLOAT))
        throw Error("compare: cannot read back " + tmp);
    const int Z = 4, pad = 4, sw = 4 * w * Z + 3 * pad;
    OIIO::ImageBuf sheet(OIIO::ImageSpec(sw, h * Z, 3, OIIO::TypeDesc::UINT8));
    auto put = [&](int panel, int x, int y, const float* c) {
        for (int j = 0; j < Z; ++j)
            for (int i = 0; i < Z; ++i)
                sheet.setpixel(panel * (w * Z + pad) + x * Z + i, y * Z + j, c, 3);
    };
    OIIO::ImageBufAlgo::fill(sheet, {0.5f, 0.5f, 0.5f});
    std::vector<float> px(3);
    for (int k = 0; k < 3; ++k)
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x) {
                in.getpixel(k * w + x, y, px.data(), 3);
                put(k, x, y, px.data());
            }
    const Aov& ra = requireAov(ref, "beauty");
    const Aov& wa = requireAov(wkb, "beauty");
    float peak = 0;
    for (int i = 0; i < n; ++i)
        peak = std::max(peak, std::fabs(lum(wa, size_t(i)) - lum(ra, size_t(i))));
    const float scale = peak > 0 ? 1.0f / peak : 1.0f;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            const size_t i = size_t(y) * w + x;
            const float d = std::clamp((lum(wa, i) - lum(ra, i)) * scale, -1.0f, 1.0f);
            float c[3] = {1 - std::max(-d, 0.0f), 1 - std::fabs(d), 1 - std::max(d, 0.0f)};
            put(3, x, y, c);
        }
    fs::remove(tmp);
    if (!sheet.write(path))
        throw Error("compare: cannot write " + path + ": " + sheet.geterror());
}

void writeAtomic(const std::string& path, const std::string& text)
{
    AtomicFile file(path);
    {
        std::ofstream out(file.tempPath(), std::ios::binary);
        out << text;
        if (!out)
            throw Error("compare: cannot write " + file.tempPath());
    }
    file.commit();
}

std::string rowsToCsv(const std::vector<CompareRow>& rows)
{
    std::ostringstream o;
    o << "method,label,source,kernel,seed,seconds,spp";
    for (const char* a : {"beauty", "L1", "L2plus"})
        o << "," << a << "_relmse," << a << "_meanrel," << a << "_energyrel";
    o << ",pt_seconds_to_equal_beauty_relmse\n";
    for (const CompareRow& r : rows) {
        o << r.method << "," << r.label << "," << r.source << "," << r.kernel << "," << r.seed << ","
          << fmt("%.4f", r.seconds) << "," << r.spp;
        for (const ErrorMetrics* m : {&r.beauty, &r.L1, &r.L2plus})
            o << "," << fmt("%.6g", m->relMse) << "," << fmt("%.6g", m->meanRel) << "," << fmt("%.6g", m->energyRel);
        o << "," << (r.method == "wkb" ? fmt("%.4g", ptTimeToError(rows, r.beauty.relMse)) : std::string()) << "\n";
    }
    return o.str();
}

}  // namespace

ErrorMetrics measureError(const Film& x, const Film& ref, const std::string& aov)
{
    const Aov& a = requireAov(x, aov);
    const Aov& r = requireAov(ref, aov);
    if (x.width != ref.width || x.height != ref.height)
        throw Error("compare: film sizes differ");
    const int n = ref.width * ref.height;
    const double m = meanOf(r, n);
    const double eps = std::max((0.1 * m) * (0.1 * m), 1e-20);
    double se = 0, absErr = 0, absRef = 0, sx = 0, sr = 0;
    for (int i = 0; i < n; ++i)
        for (int c = 0; c < 3; ++c) {
            const double p = a.pixels[size_t(i) * size_t(a.channels) + size_t(c)];
            const double q = r.pixels[size_t(i) * size_t(r.channels) + size_t(c)];
            se += (p - q) * (p - q) / (q * q + eps);
            absErr += std::fabs(p - q);
            absRef += std::fabs(q);
            sx += p;
            sr += q;
        }
    ErrorMetrics e;
    e.relMse = se / std::max(1, 3 * n);
    e.meanRel = absRef > 0 ? absErr / absRef : 0;
    e.energyRel = sr != 0 ? (sx - sr) / sr : 0;
    return e;
}

double referenceNoiseRelMse(const Film& ref)
{
    const Aov* v = ref.find("variance");
    const Aov* b = ref.find("beauty");
    if (!v || !b)
        return 0;
    const int n = ref.width * ref.height;
    std::vector<double> y(static_cast<size_t>(n));
    double m = 0;
    for (int i = 0; i < n; ++i)
        m += (y[size_t(i)] = lum(*b, size_t(i)));
    m /= std::max(1, n);
    const double eps = (0.1 * m) * (0.1 * m) + 1e-20;
    double s = 0;
    for (int i = 0; i < n; ++i)
        s += v->pixels[size_t(i)] / (y[size_t(i)] * y[size_t(i)] + eps);
    return s / std::max(1, n);
}

double ptTimeToError(const std::vector<CompareRow>& rows, double relMse)
{
    // Seed-averaged (time, relMSE) per ladder label.
    std::map<std::string, std::pair<double, double>> sum;
    std::map<std::string, int> count;
    for (const CompareRow& r : rows)
        if (r.method == "pathtrace" && r.label.rfind("t=", 0) == 0) {
            auto& s = sum[r.label];
            s.first += r.seconds, s.second += r.beauty.relMse;
            ++count[r.label];
        }
    std::vector<std::pair<double, double>> pts;
    for (auto& [label, s] : sum)
        pts.push_back({s.first / count[label], s.second / count[label]});
    if (pts.empty() || !(relMse > 0))
        return 0;
    std::sort(pts.begin(), pts.end());
    for (size_t i = 0; i + 1 < pts.size(); ++i) {
        const auto& [t0, e0] = pts[i];
        const auto& [t1, e1] = pts[i + 1];
        if ((relMse <= e0 && relMse >= e1) || (relMse >= e0 && relMse <= e1)) {
            if (e0 == e1)
                return t0;
            const double f = std::log(relMse / e0) / std::log(e1 / e0);
            return std::exp(std::log(t0) + f * (std::log(t1) - std::log(t0)));
        }
    }
    // Outside the measured range: relMSE of an unbiased estimator falls as 1/t.
    const auto& end = relMse < pts.back().second ? pts.back() : pts.front();
    return end.first * end.second / relMse;
}

CompareResult runCompare(const Scene& input, const CompareOptions& opt)
{
    CompareResult result;
    fs::create_directories(opt.outDir);
    auto say = [&](const std::string& s) {
        if (!opt.quiet)
            std::fprintf(stderr, "nimbus compare: %s\n", s.c_str());
    };

    // Reference: the path tracer, long, cached by the scene document's hash.
    Scene refScene = input;
    refScene.render.method = Method::Pathtrace;
    refScene.render.spp = 1 << 24;
    refScene.render.maxDepth = 0;  // unbounded whatever the scene says: a depth cap biases the reference
    refScene.render.timeLimit = 45.0 * opt.minutes;
    refScene.render.seed = 0x5eed0001u;
    refScene.output.preview.clear();
    nlohmann::json doc = sceneToJson(refScene);
    doc.erase("output");
    const uint64_t key = fnv1a(doc.dump());
    char hex[17];
    std::snprintf(hex, sizeof(hex), "%016llx", static_cast<unsigned long long>(key));
    const std::string cacheDir = opt.cacheDir.empty() ? defaultCacheDir() + "/compare" : opt.cacheDir;
    const std::string cachePath = cacheDir + "/ref-" + hex + ".bin";
    Film ref;
    if (loadReference(cachePath, ref) && ref.width == input.camera.width && ref.height == input.camera.height) {
        result.referenceCached = true;
        say("reference from cache " + cachePath);
    } else {
        say("rendering the reference (" + fmt("%.0f", refScene.render.timeLimit) + " s)...");
        RenderResult r = render(refScene);
        ref = r.film;
        result.referenceSeconds = r.seconds;
        saveReference(ref, cachePath);
        writeExr(ref, opt.outDir + "/reference.exr");
    }
    if (ref.x0 != 0 || ref.y0 != 0 || ref.x1 != ref.width || ref.y1 != ref.height)
        throw InputError("compare: the scene must render the full frame (no crop)");
    result.referenceNoise = referenceNoiseRelMse(ref);

    std::vector<CompareRow>& rows = result.rows;
    Scene base = input;
    base.output.preview.clear();

    // (a) The path tracer: K seeds at a ladder of time limits.
    Scene pt = base;
    pt.render.method = Method::Pathtrace;
    pt.render.spp = 1 << 24;
    pt.render.maxDepth = 0;  // the same estimator as the reference, so its error is noise alone
    for (double t : {0.5, 1.0, 2.0, 4.0, 8.0}) {
        const double limit = t * opt.minutes;
        for (int k = 0; k < opt.seeds; ++k) {
            pt.render.timeLimit = limit;
            pt.render.seed = 1000u + uint32_t(k);
            RenderResult r = render(pt);
            rows.push_back(makeRow("pathtrace", "t=" + fmt("%g", limit) + "s", pt, r, ref));
            say("pathtrace " + rows.back().label + " seed " + std::to_string(k) + ": beauty relMSE " +
                fmt("%.3g", rows.back().beauty.relMse));
        }
    }

    // (b) WKB: each source model x kernel at the scene's settings, then a quality ladder on the
    // scene's own model.
    Scene wkb = base;
    wkb.render.method = Method::Wkb;
    Film baseWkb;
    double baseWkbSeconds = 0;
    for (WkbSource src : {WkbSource::Straight, WkbSource::RandomWalk})
        for (WkbKernel ker : {WkbKernel::Gaussian, WkbKernel::Exact}) {
            Scene s = wkb;
            s.render.wkbSource = src;
            s.render.wkbKernel = ker;
            RenderResult r = render(s);
            rows.push_back(makeRow("wkb", "base", s, r, ref));
            say(std::string("wkb ") + wkbSourceName(src) + "/" + wkbKernelName(ker) + ": beauty relMSE " +
                fmt("%.3g", rows.back().beauty.relMse) + ", L2plus energy " + fmt("%+.3f", rows.back().L2plus.energyRel) +
                ", " + fmt("%.2f", r.seconds) + " s");
            if (src == input.render.wkbSource && ker == input.render.wkbKernel) {
                baseWkb = r.film;
                baseWkbSeconds = r.seconds;
            }
        }
    struct Step {
        const char* label;
        float lStep;
        int orderMax, lightRes, shadowRes, spp;
    };
    std::vector<Step> ladder = {{"coarse", 1.0f, 16, 16, 64, 1}, {"fast", 0.5f, 32, 32, 128, 2},
                                {"fine", 0.125f, 256, 0, 512, 8}};
    if (opt.fullLadder) {
        ladder.push_back({"lstep0.0625", 0.0625f, 128, 0, 256, 4});
        ladder.push_back({"order8", 0.25f, 8, 0, 256, 4});
        ladder.push_back({"lightres64", 0.25f, 128, 64, 256, 4});
        ladder.push_back({"lightres128", 0.25f, 128, 128, 256, 4});
        ladder.push_back({"smr1024", 0.25f, 128, 0, 1024, 4});
        ladder.push_back({"spp32", 0.25f, 128, 0, 256, 32});
    }
    for (const Step& st : ladder) {
        Scene s = wkb;
        s.render.wkbLStep = st.lStep;
        s.render.wkbOrderMax = st.orderMax;
        s.render.lightVolumeResolution = st.lightRes;
        s.render.shadowMapResolution = st.shadowRes;
        s.render.spp = st.spp;
        RenderResult r = render(s);
        rows.push_back(makeRow("wkb", st.label, s, r, ref));
        say(std::string("wkb ") + st.label + ": beauty relMSE " + fmt("%.3g", rows.back().beauty.relMse) + ", " +
            fmt("%.2f", r.seconds) + " s");
    }
    {
        Scene s = base;
        s.render.method = Method::Single;
        RenderResult r = render(s);
        rows.push_back(makeRow("single", "base", s, r, ref));
    }

    // The path tracer at WKB's time, for the sheet.
    pt.render.timeLimit = std::max(0.05, baseWkbSeconds);
    pt.render.seed = 2000u;
    RenderResult eq = render(pt);
    rows.push_back(makeRow("pathtrace", "equal-time", pt, eq, ref));

    writeAtomic(opt.outDir + "/compare.csv", rowsToCsv(rows));
    writeErrorChart(rows, opt.outDir + "/error_vs_time.png",
                    input.sourcePath.empty() ? "nimbus compare" : fs::path(input.sourcePath).filename().string());
    writeSheet(ref, baseWkb, eq.film, opt.outDir + "/sheet.png", opt.outDir);

    // summary.md
    std::ostringstream md;
    md << "# nimbus compare: " << (input.sourcePath.empty() ? "(scene)" : input.sourcePath) << "\n\n";
    md << "Reference: path tracer, " << sppOf(ref) << " spp"
       << (result.referenceCached ? " (cached)" : ", " + fmt("%.1f", result.referenceSeconds) + " s")
       << "; its own beauty relMSE (from its variance) " << fmt("%.3g", result.referenceNoise)
       << ", the floor under every error below.\n\n";
    md << "| method | step | source | kernel | time s | beauty relMSE | beauty energy | L1 energy | L2plus energy | "
          "L2plus meanRel | PT time to equal beauty relMSE s |\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    for (const CompareRow& r : rows) {
        if (r.method == "pathtrace" && r.seed != 1000u && r.label != "equal-time")
            continue;
        md << "| " << r.method << " | " << r.label << " | " << r.source << " | " << r.kernel << " | "
           << fmt("%.2f", r.seconds) << " | " << fmt("%.3g", r.beauty.relMse) << " | " << fmt("%+.3f", r.beauty.energyRel)
           << " | " << fmt("%+.3f", r.L1.energyRel) << " | " << fmt("%+.3f", r.L2plus.energyRel) << " | "
           << fmt("%.3f", r.L2plus.meanRel) << " | "
           << (r.method == "wkb" ? fmt("%.2f", ptTimeToError(rows, r.beauty.relMse)) : std::string("")) << " |\n";
    }
    md << "\nFiles: compare.csv (every run, every seed), error_vs_time.png, sheet.png (reference | WKB "
       << wkbSourceName(input.render.wkbSource) << "/" << wkbKernelName(input.render.wkbKernel)
       << " | path tracer at WKB's time | WKB - reference, luminance, red brighter, blue darker, full scale the largest difference).\n";
    writeAtomic(opt.outDir + "/summary.md", md.str());
    say("wrote " + opt.outDir + "/{compare.csv,error_vs_time.png,sheet.png,summary.md}");
    return result;
}

}  // namespace nimbus
