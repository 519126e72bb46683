#include "DataFiles.h"

#include <dlfcn.h>

#include <filesystem>

namespace nimbus {

namespace fs = std::filesystem;

namespace {

// <prefix>/share/nimbus when the module holding this function sits in <prefix>/bin/, lib/ or a
// multiarch lib/<triplet>/ and the install laid the kernels there; empty otherwise.
fs::path installedShare()
{
    Dl_info info{};
    if (!dladdr(reinterpret_cast<void*>(&installedShare), &info) || !info.dli_fname)
        return {};
    std::error_code ec;
    // For the main program glibc reports argv[0], which has no '/' when it was found on $PATH.
    const std::string name = info.dli_fname;
    fs::path module = name.find('/') == std::string::npos ? fs::read_symlink("/proc/self/exe", ec)
                                                          : fs::canonical(fs::path(name), ec);
    if (ec)
        return {};
    fs::path dir = module.parent_path();
    for (int up = 0; up < 2 && dir.has_parent_path(); ++up) {
        dir = dir.parent_path();
        fs::path share = dir / NIMBUS_INSTALL_DATADIR / "nimbus";
        if (fs::is_regular_file(share / "kernels" / "pathtrace.cl", ec))
            return share;
    }
    return {};
}

}  // namespace

std::string dataPath(DataFile which)
{
    static const fs::path share = installedShare();
    const bool installed = !share.empty();
    const fs::path root = installed ? share : fs::path(NIMBUS_SOURCE_DIR);
    switch (which) {
    case DataFile::Kernels: return (root / "kernels").string();
    case DataFile::Shaders: return (root / "shaders").string();
    case DataFile::OcioConfig:
        return (installed ? root / "ocio" / "config.ocio" : root / "src" / "io" / "ocio" / "config.ocio").string();
    case DataFile::CompareCharts:
        return (installed ? root / "compare" / "compare_charts.py" : root / "src" / "compare" / "compare_charts.py")
            .string();
    }
    return {};
}

}  // namespace nimbus
