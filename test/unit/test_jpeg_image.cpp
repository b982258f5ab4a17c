// Raw camera images as JPEG (core/jpeg_image.h): decoded back, the colours stay in place; wrong input is refused.
#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>

#include "xpersif/core/common/validation.h"
#include "xpersif/core/web/jpeg_image.h"

using namespace xpersif::core;

namespace {

/// A width × height rgb8 image: the left half red, the right half blue.
std::vector<std::uint8_t> halves(std::uint32_t width, std::uint32_t height) {
  std::vector<std::uint8_t> rgb(std::size_t{width} * height * 3, 0);
  for (std::uint32_t y = 0; y < height; ++y) {
    for (std::uint32_t x = 0; x < width; ++x) rgb[(std::size_t{y} * width + x) * 3 + (x < width / 2 ? 0 : 2)] = 255;
  }
  return rgb;
}

}  // namespace

TEST(JpegImage, AnRgbImageDecodesWithItsSizeAndColours) {
  const auto rgb = halves(64, 48);
  const auto jpeg = encodeJpeg({64, 48, 64 * 3, "rgb8", rgb.data(), rgb.size()}, 90);
  ASSERT_GT(jpeg.size(), 3u);
  EXPECT_EQ(jpeg[0], 0xFF);
  EXPECT_EQ(jpeg[1], 0xD8);  // JPEG's start-of-image marker
  const cv::Mat decoded = cv::imdecode(jpeg, cv::IMREAD_COLOR);  // BGR
  ASSERT_EQ(decoded.cols, 64);
  ASSERT_EQ(decoded.rows, 48);
  const cv::Vec3b left = decoded.at<cv::Vec3b>(24, 8), right = decoded.at<cv::Vec3b>(24, 56);
  EXPECT_GT(left[2], 200);   // red on the left
  EXPECT_LT(left[0], 60);
  EXPECT_GT(right[0], 200);  // blue on the right
  EXPECT_LT(right[2], 60);
}

TEST(JpegImage, OtherEncodingsAndShortBuffersAreRefused) {
  const auto rgb = halves(8, 8);
  EXPECT_THROW(encodeJpeg({8, 8, 8 * 3, "32FC1", rgb.data(), rgb.size()}, 90), ValidationError);
  EXPECT_THROW(encodeJpeg({8, 9, 8 * 3, "rgb8", rgb.data(), rgb.size()}, 90), ValidationError);
  EXPECT_THROW(encodeJpeg({8, 8, 8 * 2, "rgb8", rgb.data(), rgb.size()}, 90), ValidationError);
  EXPECT_THROW(encodeJpeg({8, 8, 8 * 3, "rgb8", rgb.data(), rgb.size()}, 0), ValidationError);
}
