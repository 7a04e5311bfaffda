// SPDX-License-Identifier: MIT
// modrt_compare_images: the golden-image metric (delta_e.h) of two images of the same size,
// for tests that compare the outputs of two programs (ctest embed_host_scene_matches_demo).
//
//   modrt_compare_images A.png B.png [--max-mean M] [--max-p99 P] [--differ]
//
// Prints "delta E mean X, p99 Y". Exit status 0 when mean <= M and p99 <= P (defaults 1 and
// 8, the golden test's bounds), 1 when not; with --differ the other way round (the images must
// fail those bounds: a check that the comparison can fail). 2 for bad arguments or images.
#include <cstdio>
#include <cstdlib>
#include <memory>
#include <string>
#include <vector>

#include <OpenImageIO/imageio.h>

#include "delta_e.h"

namespace {

bool read_rgb8(const std::string& path, int& width, int& height, std::vector<std::uint8_t>& rgb) {
  std::unique_ptr<OIIO::ImageInput> in = OIIO::ImageInput::open(path);
  if (!in) {
    std::fprintf(stderr, "modrt_compare_images: %s: %s\n", path.c_str(), OIIO::geterror().c_str());
    return false;
  }
  const OIIO::ImageSpec& spec = in->spec();
  width = spec.width, height = spec.height;
  if (spec.nchannels < 3) {
    std::fprintf(stderr, "modrt_compare_images: %s: %d channels, RGB expected\n", path.c_str(),
                 spec.nchannels);
    return false;
  }
  std::vector<std::uint8_t> all(std::size_t(width) * std::size_t(height) * std::size_t(spec.nchannels));
  if (!in->read_image(0, 0, 0, spec.nchannels, OIIO::TypeDesc::UINT8, all.data())) {
    std::fprintf(stderr, "modrt_compare_images: %s: %s\n", path.c_str(), in->geterror().c_str());
    return false;
  }
  rgb.resize(std::size_t(width) * std::size_t(height) * 3);
  for (std::size_t p = 0; p < std::size_t(width) * std::size_t(height); ++p)
    for (std::size_t c = 0; c < 3; ++c) rgb[3 * p + c] = all[p * std::size_t(spec.nchannels) + c];
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> files;
  double max_mean = 1.0, max_p99 = 8.0;
  bool differ = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if ((a == "--max-mean" || a == "--max-p99") && i + 1 < argc) {
      char* end = nullptr;
      const double v = std::strtod(argv[++i], &end);
      if (!end || *end || !(v >= 0.0)) {
        std::fprintf(stderr, "modrt_compare_images: %s: '%s' is not a number >= 0\n", a.c_str(), argv[i]);
        return 2;
      }
      (a == "--max-mean" ? max_mean : max_p99) = v;
    } else if (a == "--differ") {
      differ = true;
    } else if (!a.empty() && a[0] != '-') {
      files.push_back(a);
    } else {
      files.clear();
      break;
    }
  }
  if (files.size() != 2) {
    std::fprintf(stderr, "usage: modrt_compare_images A.png B.png [--max-mean M] [--max-p99 P] [--differ]\n");
    return 2;
  }
  int wa = 0, ha = 0, wb = 0, hb = 0;
  std::vector<std::uint8_t> a, b;
  if (!read_rgb8(files[0], wa, ha, a) || !read_rgb8(files[1], wb, hb, b)) return 2;
  if (wa != wb || ha != hb) {
    std::fprintf(stderr, "modrt_compare_images: %s is %dx%d, %s is %dx%d\n", files[0].c_str(), wa, ha,
                 files[1].c_str(), wb, hb);
    return 2;
  }
  const modrt::test::DeltaE e = modrt::test::delta_e(a, b);
  double max = 0.0;
  std::size_t differing = 0;
  for (std::size_t i = 0; i + 2 < a.size(); i += 3) {
    const double d = glm::length(modrt::test::lab(&a[i]) - modrt::test::lab(&b[i]));
    max = std::max(max, d);
    differing += d > 0.0;
  }
  const bool within = e.mean <= max_mean && e.p99 <= max_p99;
  std::printf(
      "delta E mean %.3f, p99 %.3f, max %.3f, %zu of %zu pixels differ (%s vs %s; bounds mean <= %g, p99 <= "
      "%g: "
      "%s)\n",
      e.mean, e.p99, max, differing, a.size() / 3, files[0].c_str(), files[1].c_str(), max_mean, max_p99,
      within ? "within" : "outside");
  return within != differ ? 0 : 1;
}
