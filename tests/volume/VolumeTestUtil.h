// VolumeTestUtil.h: scenes with one volume, sampling in world space, a scratch directory and a
// log catcher, shared by the volume tests.
#pragma once

#include "core/Error.h"
#include "core/Log.h"
#include "volume/VolumeData.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <unistd.h>

namespace nimbus::test {

// A fresh directory per test, removed afterwards, so tests can run in parallel.
class ScratchDir {
public:
    ScratchDir()
    {
        const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
        mPath = std::filesystem::temp_directory_path() /
                ("nimbus-volume-" + std::to_string(getpid()) + "-" + info->test_suite_name() + "-" + info->name());
        std::filesystem::remove_all(mPath);
        std::filesystem::create_directories(mPath);
    }
    ~ScratchDir() { std::filesystem::remove_all(mPath); }
    std::string operator/(const std::string& name) const { return (mPath / name).string(); }
    std::string str() const { return mPath.string(); }

private:
    std::filesystem::path mPath;
};

inline void writeText(const std::string& path, const std::string& text)
{
    std::ofstream(path) << text;
}

inline Scene proceduralScene(const std::string& generator, std::map<std::string, double> params,
                             const std::string& shader = "")
{
    Scene scene;
    scene.sourcePath = "scene.json";
    Volume v;
    v.name = generator;
    v.source.type = SourceType::Procedural;
    v.source.generator = generator;
    v.source.params = std::move(params);
    v.shader = shader;
    scene.volumes.push_back(v);
    return scene;
}

inline Scene vdbScene(const std::string& file, std::map<std::string, std::string> grids = {},
                      const std::string& shader = "")
{
    Scene scene;
    scene.sourcePath = "scene.json";
    Volume v;
    v.name = "cloud";
    v.source.type = SourceType::Vdb;
    v.source.file = file;
    v.source.grids = std::move(grids);
    v.shader = shader;
    scene.volumes.push_back(v);
    return scene;
}

inline std::shared_ptr<VolumeData> buildOne(const Scene& scene)
{
    auto volumes = buildVolumes(scene);
    EXPECT_EQ(volumes.size(), 1u);
    return volumes.at(0);
}

inline float densityAt(const VolumeData& v, float3 world)
{
    return v.density.sample(v.indexFromWorld.point(world));
}
inline float3 emissionAt(const VolumeData& v, float3 world)
{
    return v.emission.sample3(v.indexFromWorld.point(world));
}

// The InputError message buildVolumes throws for `scene` ("" if none).
inline std::string inputError(const Scene& scene)
{
    try {
        buildVolumes(scene);
    } catch (const InputError& e) {
        return e.what();
    }
    return "";
}

// Collects warnings while alive.
class LogCatcher {
public:
    LogCatcher()
    {
        setLogSink([this](LogLevel level, const std::string& m) {
            if (level == LogLevel::Warning)
                warnings.push_back(m);
        });
    }
    ~LogCatcher() { setLogSink(nullptr); }
    std::vector<std::string> warnings;
};

}  // namespace nimbus::test
