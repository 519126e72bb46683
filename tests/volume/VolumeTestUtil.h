// VolumeTestUtil.h: scenes with one volume, sampling in world space, a scratch directory and a
// log catcher, shared by the volume tests.
#pragma once

#include "core/Error.h"
#include "core/Log.h"
#include "core/StopFlag.h"
#include "volume/VolumeData.h"

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <functional>
#include <optional>
#include <string>
#include <thread>
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

// Runs `work` with a StopFlag that another thread raises after `delayMs`. Returns the seconds
// from the raise to the throw of Cancelled, or nothing when `work` ended without it.
inline std::optional<double> secondsToCancel(const std::function<void(const StopFlag*)>& work, int delayMs)
{
    StopFlag stop;
    std::chrono::steady_clock::time_point raised;
    std::thread canceller([&] {
        std::this_thread::sleep_for(std::chrono::milliseconds(delayMs));
        raised = std::chrono::steady_clock::now();
        stop.raise();
    });
    bool cancelled = false;
    try {
        work(&stop);
    } catch (const Cancelled&) {
        cancelled = true;
    }
    const auto ended = std::chrono::steady_clock::now();
    canceller.join();
    if (!cancelled)
        return std::nullopt;
    return std::chrono::duration<double>(ended - raised).count();
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
