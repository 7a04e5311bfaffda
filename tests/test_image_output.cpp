// SPDX-License-Identifier: MIT
// The demo's image writer (demo/image_output.h, issue 18): a linear EXR frame is stored as half
// floats while every value fits their range and as float32 beyond it (a glTF light of 1e8 cd
// gave Inf pixels in half; 1e20 cd made every pixel Inf), and a frame holding NaN or Inf is
// refused with the count, so nothing non-finite is ever written. Read back with OpenImageIO.
#include <gtest/gtest.h>

#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>

#include "image_output.h"

namespace modrt::demo {
namespace {

namespace fs = std::filesystem;

fs::path temp_path(const std::string& name) {
  static const fs::path dir = [] {
    fs::path d = fs::temp_directory_path() / ("modrt_test_image_" + std::to_string(::getpid()));
    fs::create_directories(d);
    return d;
  }();
  return dir / name;
}

struct ReadBack {
  OIIO::TypeDesc format;
  std::vector<float> rgb;
};

ReadBack read_exr(const fs::path& path) {
  auto in = OIIO::ImageInput::open(path.string());
  EXPECT_TRUE(in) << path << ": " << OIIO::geterror();
  if (!in) return {};
  ReadBack r;
  r.format = in->spec().format;
  r.rgb.resize(std::size_t(in->spec().width) * std::size_t(in->spec().height) * 3);
  EXPECT_TRUE(in->read_image(0, 0, 0, 3, OIIO::TypeDesc::FLOAT, r.rgb.data()));
  in->close();
  return r;
}

TEST(ImageOutput, ExrIsHalfWithinHalfRangeAndFloat32Beyond) {
  // 2 x 1 pixels. Within half's range (largest finite half: 65504): half, 11-bit precision.
  const std::vector<float> small = {0.5f, 1.0f, 2.0f, 65504.0f, 0.25f, 0.0f};
  bool float32 = true;
  ASSERT_TRUE(write_rgb_float_image(temp_path("small.exr").string(), 2, 1, small, &float32).ok());
  EXPECT_FALSE(float32);
  const ReadBack a = read_exr(temp_path("small.exr"));
  EXPECT_EQ(a.format, OIIO::TypeDesc::HALF);
  EXPECT_EQ(a.rgb, small);
  // One value past it (1e8 cd at a metre is ~1.5e5): float32, every value exact and finite.
  const std::vector<float> bright = {0.5f, 1.0f, 2.0f, 65520.0f, 1.5e17f, 3.0e38f};
  ASSERT_TRUE(write_rgb_float_image(temp_path("bright.exr").string(), 2, 1, bright, &float32).ok());
  EXPECT_TRUE(float32);
  const ReadBack b = read_exr(temp_path("bright.exr"));
  EXPECT_EQ(b.format, OIIO::TypeDesc::FLOAT);
  EXPECT_EQ(b.rgb, bright);  // as half, 65520 and above read back as Inf
}

TEST(ImageOutput, NonFiniteFramesAreRefusedWithTheCount) {
  const float inf = std::numeric_limits<float>::infinity(), nan = std::numeric_limits<float>::quiet_NaN();
  const std::vector<float> rgb = {0.5f, inf, 2.0f, nan, 0.25f, -inf};
  EXPECT_EQ(count_non_finite(rgb), 3u);
  const fs::path path = temp_path("nan.exr");
  const Status s = write_rgb_float_image(path.string(), 2, 1, rgb);
  ASSERT_FALSE(s.ok());
  EXPECT_EQ(s.code(), ErrorCode::non_finite);
  EXPECT_NE(s.message().find("nan.exr: 3 of 6 values are not finite"), std::string::npos) << s.message();
  EXPECT_FALSE(fs::exists(path));
}

}  // namespace
}  // namespace modrt::demo
