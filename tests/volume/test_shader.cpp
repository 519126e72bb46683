// Volume shaders (OpenVDB AX) on procedural volumes: lookup, errors, custom density and emission.
#include "VolumeTestUtil.h"
#include "volume/VolumeShader.h"

#include <cstdlib>

using namespace nimbus;
using namespace nimbus::test;

namespace {
Scene boxWithShader(const std::string& shader)
{
    return proceduralScene("box", {{"size", 1.0}, {"voxel_size", 0.125}, {"density", 2.0}}, shader);
}
}  // namespace

TEST(VolumeShader, DefaultIsFoundAndRecognised)
{
    for (std::string name : {"", "default", "default.ax"}) {
        ShaderFile f = findShader(name, "", "scene.json: volumes[0].shader");
        EXPECT_TRUE(f.isDefault) << name;
        EXPECT_NE(f.path.find("shaders/default.ax"), std::string::npos) << name;
    }
    EXPECT_FALSE(findShader("blackbody", "", "x").isDefault);
}

TEST(VolumeShader, MissingShaderNamesTheKey)
{
    std::string e = inputError(boxWithShader("nosuch"));
    EXPECT_EQ(e.rfind("scene.json: volumes[0].shader: shader 'nosuch' not found (searched: ", 0), 0u) << e;
    EXPECT_EQ(e.find('\n'), std::string::npos);
}

TEST(VolumeShader, CompileErrorIsAnInputErrorWithTheAxMessage)
{
    ScratchDir dir;
    writeText(dir / "broken.ax", "@density = max(@density, 0.0f;\n");
    std::string e = inputError(boxWithShader(dir / "broken.ax"));
    EXPECT_EQ(e.rfind("scene.json: volumes[0].shader: AX error in '", 0), 0u) << e;
    EXPECT_NE(e.find("expecting"), std::string::npos) << e;
    EXPECT_EQ(e.find('\n'), std::string::npos);

    writeText(dir / "unknown.ax", "@density = nosuchfunction(@density);\n");
    e = inputError(boxWithShader(dir / "unknown.ax"));
    EXPECT_NE(e.find("nosuchfunction"), std::string::npos) << e;
}

TEST(VolumeShader, ReadingAGridNobodySuppliedIsAnInputError)
{
    ScratchDir dir;
    writeText(dir / "reads.ax", "@density = @smoke;\n");
    std::string e = inputError(boxWithShader(dir / "reads.ax"));
    EXPECT_NE(e.find("volumes[0].shader"), std::string::npos) << e;
    EXPECT_NE(e.find("smoke"), std::string::npos) << e;
}

TEST(VolumeShader, CustomShaderMapsDensityAndEmission)
{
    ScratchDir dir;
    writeText(dir / "glow.ax", "// a test shader\n"
                               "@density = 3.0f * @density;\n"
                               "v@emission = {0.5f, 0.25f, 0.0f} * @density;\n");
    auto v = buildOne(boxWithShader(dir / "glow.ax"));
    EXPECT_EQ(densityAt(*v, make_float3(0.1f, 0.2f, -0.3f)), 6.0f);
    ASSERT_TRUE(v->hasEmission());
    EXPECT_EQ(v->emission.channels(), 3);
    float3 e = emissionAt(*v, make_float3(0.1f, 0.2f, -0.3f));
    EXPECT_FLOAT_EQ(e.x, 3.0f);
    EXPECT_FLOAT_EQ(e.y, 1.5f);
    EXPECT_EQ(e.z, 0.0f);
    EXPECT_EQ(emissionAt(*v, make_float3(0.8f, 0, 0)).x, 0.0f);
}

TEST(VolumeShader, NegativeShaderOutputIsClampedAndCounted)
{
    ScratchDir dir;
    writeText(dir / "negate.ax", "@density = -@density;\n");
    LogCatcher log;
    auto v = buildOne(boxWithShader(dir / "negate.ax"));
    EXPECT_TRUE(v->density.empty());
    EXPECT_EQ(v->clampedVoxels, 8u * 8u * 8u);
    ASSERT_EQ(log.warnings.size(), 1u);
    EXPECT_NE(log.warnings[0].find("clamped 512 voxel values (512 negative, 0 NaN, 0 infinite) to 0 [density]"),
              std::string::npos)
        << log.warnings[0];
}

TEST(VolumeShader, SearchPathFromEnvironment)
{
    ScratchDir dir;
    writeText(dir / "half.ax", "@density = 0.5f * @density;\n");
    ::setenv("NIMBUS_SHADER_PATH", ("/nonexistent:" + dir.str()).c_str(), 1);
    auto v = buildOne(boxWithShader("half"));
    ::unsetenv("NIMBUS_SHADER_PATH");
    EXPECT_EQ(densityAt(*v, make_float3(0, 0, 0)), 1.0f);
}

TEST(VolumeShader, ShaderNextToTheScene)
{
    ScratchDir dir;
    writeText(dir / "double.ax", "@density = 2.0f * @density;\n");
    Scene scene = boxWithShader("double");
    scene.sourcePath = dir / "scene.json";
    EXPECT_EQ(densityAt(*buildOne(scene), make_float3(0, 0, 0)), 4.0f);
    scene.volumes[0].shader = "./double.ax";
    EXPECT_EQ(densityAt(*buildOne(scene), make_float3(0, 0, 0)), 4.0f);
}

TEST(VolumeShader, DefaultShaderOnDensityOnlyVolumeLeavesEmissionOff)
{
    for (std::string shader : {"", "default"}) {
        auto v = buildOne(boxWithShader(shader));
        EXPECT_FALSE(v->hasEmission());
        EXPECT_EQ(densityAt(*v, make_float3(0, 0, 0)), 2.0f);
    }
    // blackbody.ax on a volume without temperature: it runs, and nothing glows.
    auto v = buildOne(boxWithShader("blackbody"));
    EXPECT_FALSE(v->hasEmission());
    EXPECT_EQ(densityAt(*v, make_float3(0, 0, 0)), 2.0f);
}

TEST(VolumeShader, OneCompilePerShaderForManyVolumes)
{
    ScratchDir dir;
    writeText(dir / "triple.ax", "@density = 3.0f * @density;\n");
    Scene scene = boxWithShader(dir / "triple.ax");
    scene.volumes.push_back(scene.volumes[0]);
    scene.volumes[1].transform = Transform::translate(5, 0, 0);
    auto volumes = buildVolumes(scene);
    ASSERT_EQ(volumes.size(), 2u);
    EXPECT_EQ(densityAt(*volumes[0], make_float3(0, 0, 0)), 6.0f);
    EXPECT_EQ(densityAt(*volumes[1], make_float3(5, 0, 0)), 6.0f);
    EXPECT_EQ(densityAt(*volumes[1], make_float3(0, 0, 0)), 0.0f);
}

// A relative shader resolves beside the scene first, then $NIMBUS_SHADER_PATH, then the
// built-in shaders; the error lists each place in that order.
TEST(VolumeShader, BesideTheSceneComesFirst)
{
    namespace fs = std::filesystem;
    ScratchDir dir;
    const fs::path sceneDir = dir / "scene", searchDir = dir / "search";
    fs::create_directories(sceneDir / "sub");
    fs::create_directories(searchDir);
    auto norm = [](const fs::path& p) { return p.lexically_normal().string(); };
    writeText(sceneDir / "blackbody.ax", "@density = 1.0f;\n");
    writeText(searchDir / "mine.ax", "@density = 1.0f;\n");
    writeText(sceneDir / "sub" / "mine.ax", "@density = 2.0f;\n");
    ::setenv("NIMBUS_SHADER_PATH", searchDir.c_str(), 1);
    EXPECT_EQ(findShader("blackbody", sceneDir, "x").path, norm(sceneDir / "blackbody.ax"));
    EXPECT_EQ(findShader("mine", sceneDir, "x").path, norm(searchDir / "mine.ax"));
    EXPECT_EQ(findShader("sub/mine", sceneDir, "x").path, norm(sceneDir / "sub" / "mine.ax"));
    EXPECT_NE(findShader("blackbody", "", "x").path.find("shaders/blackbody.ax"), std::string::npos);
    try {
        findShader("nowhere", sceneDir, "scene.json: volumes[0].shader");
        ADD_FAILURE() << "no InputError";
    } catch (const InputError& e) {
        const std::string m = e.what();
        const size_t scene = m.find(norm(sceneDir / "nowhere"));
        const size_t search = m.find(norm(searchDir / "nowhere"));
        const size_t builtin = m.find("shaders/nowhere.ax");
        ASSERT_NE(scene, std::string::npos) << m;
        ASSERT_NE(search, std::string::npos) << m;
        ASSERT_NE(builtin, std::string::npos) << m;
        EXPECT_LT(scene, search) << m;
        EXPECT_LT(search, builtin) << m;
    }
    ::unsetenv("NIMBUS_SHADER_PATH");
}
