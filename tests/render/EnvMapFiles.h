// EnvMapFiles.h: environment maps written as EXR files for tests (procedural texels, no data in
// the repository).
#pragma once

#include <OpenImageIO/imageio.h>
#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace nimbus::test {

// Writes W x H RGB float texels (row-major from the top row) to the test's temporary directory.
inline std::string writeEnvMap(const std::string& name, int W, int H, const std::vector<float>& rgb)
{
    const std::string path = std::string(::testing::TempDir()) + name;
    auto out = OIIO::ImageOutput::create(path);
    OIIO::ImageSpec spec(W, H, 3, OIIO::TypeDesc::FLOAT);
    EXPECT_TRUE(out && out->open(path, spec) && out->write_image(OIIO::TypeDesc::FLOAT, rgb.data()) && out->close());
    return path;
}

}  // namespace nimbus::test
